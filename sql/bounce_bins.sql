-- Wall bounces of one simulation (si_num, duration in s) summed per time bin (bins equal windows), species and wall: count, sums of |v_perp|, |v| and |v_perp|^2.
-- One GROUP BY key packs the three: KEY = (BIN * 1048576 + PA_NUM) * 8 + RE_DIR + 4, BIN = floor(RE_T * bins / duration)
-- (PA_NUM < 2^20, RE_DIR in -3..3): one key sorts about 30% faster than three in SQLite.
-- BIN is CAST(x AS BIGINT), less 1 where that is above x (x = RE_T * bins / duration): floor on both backends
-- (SQLite's CAST truncates, PostgreSQL's rounds half to even), without FLOOR, which SQLAlchemy's SQLite driver
-- runs in Python for every row.
-- A simulation without bounces gives one row with a NULL key and NB_REBONDS = 0.
SELECT ((CAST(R.RE_T * :bins / :duration AS BIGINT) - CASE WHEN CAST(R.RE_T * :bins / :duration AS BIGINT) > R.RE_T * :bins / :duration THEN 1 ELSE 0 END) * 1048576 + R.PA_NUM) * 8 + R.RE_DIR + 4 AS BIN_KEY,
       COUNT(R.RE_NUM) AS NB_REBONDS,
       SUM(R.RE_VP) AS SUM_VP,
       SUM(R.RE_VIT) AS SUM_VIT,
       SUM(R.RE_VP * R.RE_VP) AS SUM_VP2
FROM SIMULATION S
LEFT JOIN REBOND R ON R.SI_NUM = S.SI_NUM
WHERE S.SI_NUM = :si_num
GROUP BY ((CAST(R.RE_T * :bins / :duration AS BIGINT) - CASE WHEN CAST(R.RE_T * :bins / :duration AS BIGINT) > R.RE_T * :bins / :duration THEN 1 ELSE 0 END) * 1048576 + R.PA_NUM) * 8 + R.RE_DIR + 4;
