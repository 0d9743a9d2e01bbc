-- Particle-particle collisions of one simulation (si_num, duration in s; CHOC: --record all) per time bin (bins equal windows): count and sum of the impulses |J| (kg.m/s).
-- BIN = floor(CH_T * bins / duration) as CAST(... - half AS BIGINT): half = 0 on SQLite (CAST truncates), 0.5 on PostgreSQL (CAST rounds).
-- A simulation without CHOC rows gives one row with a NULL bin and NB_CHOCS = 0.
SELECT CAST(C.CH_T * :bins / :duration - :half AS BIGINT) AS BIN,
       COUNT(C.CH_NUM) AS NB_CHOCS,
       SUM(C.CH_IMP) AS SUM_IMP
FROM SIMULATION S
LEFT JOIN CHOC C ON C.SI_NUM = S.SI_NUM
WHERE S.SI_NUM = :si_num
GROUP BY CAST(C.CH_T * :bins / :duration - :half AS BIGINT)
ORDER BY BIN;
