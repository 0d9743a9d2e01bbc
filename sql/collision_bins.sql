-- Particle-particle collisions of one simulation (si_num, duration in s; CHOC: --record all) per time bin (bins equal windows): count and sum of the impulses |J| (kg.m/s).
-- BIN = floor(CH_T * bins / duration), written CAST(x AS BIGINT), less 1 where that is above x: exact on both
-- backends (SQLite's CAST truncates, PostgreSQL's rounds half to even) without FLOOR, which SQLAlchemy's SQLite driver runs in Python.
-- A simulation without CHOC rows gives one row with a NULL bin and NB_CHOCS = 0. NB_ODD counts the collisions whose CH_T or
-- CH_IMP is no number (x = x + 0 fails for text or bytes, which SQLite keeps when edited by hand and SUM reads as 0;
-- always 0 on PostgreSQL).
SELECT (CAST(C.CH_T * :bins / :duration AS BIGINT) - CASE WHEN CAST(C.CH_T * :bins / :duration AS BIGINT) > C.CH_T * :bins / :duration THEN 1 ELSE 0 END) AS BIN,
       COUNT(C.CH_NUM) AS NB_CHOCS,
       SUM(C.CH_IMP) AS SUM_IMP,
       COUNT(C.CH_NUM) FILTER (WHERE NOT (C.CH_T = C.CH_T + 0 AND C.CH_IMP = C.CH_IMP + 0)) AS NB_ODD
FROM SIMULATION S
LEFT JOIN CHOC C ON C.SI_NUM = S.SI_NUM
WHERE S.SI_NUM = :si_num
GROUP BY (CAST(C.CH_T * :bins / :duration AS BIGINT) - CASE WHEN CAST(C.CH_T * :bins / :duration AS BIGINT) > C.CH_T * :bins / :duration THEN 1 ELSE 0 END)
ORDER BY BIN;
