-- Particle-particle collisions of one simulation (si_num, duration in s; CHOC: --record all) per time bin (bins equal windows): count and sum of the impulses |J| (kg.m/s).
SELECT FLOOR(C.CH_T * :bins / :duration) AS BIN,
       COUNT(*) AS NB_CHOCS,
       SUM(C.CH_IMP) AS SUM_IMP
FROM CHOC C
WHERE C.SI_NUM = :si_num
GROUP BY FLOOR(C.CH_T * :bins / :duration)
ORDER BY BIN;
