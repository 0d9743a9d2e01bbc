-- Q35: for each simulation, the number of wall bounces recorded and the mean
-- speed (m/s) of the particles hitting a wall. Simulations without any bounce
-- are listed with 0 and a NULL mean speed.
SELECT S.SI_NUM,
       COUNT(R.RE_NUM) AS NB_REBONDS,
       AVG(R.RE_VIT) AS VITESSE_MOYENNE
FROM SIMULATION S
LEFT JOIN REBOND R ON R.SI_NUM = S.SI_NUM
GROUP BY S.SI_NUM
ORDER BY S.SI_NUM;
