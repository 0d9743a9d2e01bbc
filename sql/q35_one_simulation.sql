-- Q35 for one simulation (parameter si_num): number of wall bounces and mean speed (m/s) of the particles hitting a wall.
SELECT S.SI_NUM,
       COUNT(R.RE_NUM) AS NB_REBONDS,
       AVG(R.RE_VIT) AS VITESSE_MOYENNE
FROM SIMULATION S
LEFT JOIN REBOND R ON R.SI_NUM = S.SI_NUM
WHERE S.SI_NUM = :si_num
GROUP BY S.SI_NUM;
