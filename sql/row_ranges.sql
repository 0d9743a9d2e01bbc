-- Row numbers of one simulation (si_num) in REBOND and CHOC: first and last RE_NUM and CH_NUM (NULL when none).
-- Read from the primary keys (SI_NUM, RE_NUM) and (SI_NUM, CH_NUM) alone: a few index lookups, no table scan.
-- gaz analyse sums the rows in ranges of row numbers (sql/bounce_bins.sql, sql/collision_bins.sql).
SELECT (SELECT MIN(RE_NUM) FROM REBOND WHERE SI_NUM = :si_num) AS RE_FIRST,
       (SELECT MAX(RE_NUM) FROM REBOND WHERE SI_NUM = :si_num) AS RE_LAST,
       (SELECT MIN(CH_NUM) FROM CHOC WHERE SI_NUM = :si_num) AS CH_FIRST,
       (SELECT MAX(CH_NUM) FROM CHOC WHERE SI_NUM = :si_num) AS CH_LAST;
