-- Particle-particle collisions of one simulation (si_num, duration in s; CHOC: --record all) with row numbers first <= CH_NUM < stop, per time bin (bins equal windows): count and sum of the impulses |J| (kg.m/s).
-- BIN = floor(CH_T * bins / duration) as CAST(... - half AS BIGINT): half = 0 on SQLite (CAST truncates), 0.5 on PostgreSQL (CAST rounds).
-- Run on ranges of row numbers, as sql/bounce_bins.sql. No collision in the range: one row with a NULL bin and NB_CHOCS = 0.
SELECT CAST(C.CH_T * :bins / :duration - :half AS BIGINT) AS BIN,
       COUNT(C.CH_NUM) AS NB_CHOCS,
       SUM(C.CH_IMP) AS SUM_IMP
FROM SIMULATION S
LEFT JOIN CHOC C ON C.SI_NUM = S.SI_NUM AND C.CH_NUM >= :first AND C.CH_NUM < :stop
WHERE S.SI_NUM = :si_num
GROUP BY CAST(C.CH_T * :bins / :duration - :half AS BIGINT);
