-- Particle-particle collisions of one simulation (si_num, CHOC: --record all) per time bin (bins equal windows of SI_DUR): count and sum of the impulses |J| (kg.m/s).
SELECT FLOOR(C.CH_T * :bins / S.SI_DUR) AS BIN,
       COUNT(*) AS NB_CHOCS,
       SUM(C.CH_IMP) AS SUM_IMP
FROM CHOC C
JOIN SIMULATION S ON S.SI_NUM = C.SI_NUM
WHERE C.SI_NUM = :si_num
GROUP BY FLOOR(C.CH_T * :bins / S.SI_DUR)
ORDER BY BIN;
