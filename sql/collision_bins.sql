-- Particle-particle collisions of one simulation (si_num, duration in s; CHOC: --record all) per time bin (bins equal windows): count and sum of the impulses |J| (kg.m/s).
-- A simulation without CHOC rows gives one row with a NULL bin and NB_CHOCS = 0.
SELECT FLOOR(C.CH_T * :bins / :duration) AS BIN,
       COUNT(C.CH_NUM) AS NB_CHOCS,
       SUM(C.CH_IMP) AS SUM_IMP
FROM SIMULATION S
LEFT JOIN CHOC C ON C.SI_NUM = S.SI_NUM
WHERE S.SI_NUM = :si_num
GROUP BY FLOOR(C.CH_T * :bins / :duration)
ORDER BY BIN;
