-- Q36: for one simulation (parameter si_num), the momentum transferred to each wall over the
-- whole run, sum of 2 m |v_perp| in kg.m/s (PA_M is in grams).
-- RE_DIR = +(d+1): wall at x_d = L; -(d+1): wall at x_d = 0.
SELECT R.RE_DIR,
       SUM(2 * P.PA_M / 1000.0 * R.RE_VP) AS QUANTITE_MOUVEMENT
FROM REBOND R
JOIN PARTICULE P ON P.PA_NUM = R.PA_NUM
WHERE R.SI_NUM = :si_num
GROUP BY R.RE_DIR
ORDER BY R.RE_DIR;
