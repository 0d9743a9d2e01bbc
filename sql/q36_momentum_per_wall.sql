-- Q36: for one simulation (parameter si_num), the momentum transferred to each wall over the
-- whole run, sum of (1 + e_w) m |v_perp| in kg.m/s (PA_M is in grams; e_w the walls' restitution,
-- SCENE.SC_WALL_RESTITUTION): 2 m |v_perp| for the exam's elastic walls (and when SCENE has no row).
-- RE_DIR = +(d+1): wall at x_d = L; -(d+1): wall at x_d = 0.
SELECT R.RE_DIR,
       SUM((1 + COALESCE(SC.SC_WALL_RESTITUTION, 1.0)) * P.PA_M / 1000.0 * R.RE_VP) AS QUANTITE_MOUVEMENT
FROM REBOND R
JOIN PARTICULE P ON P.PA_NUM = R.PA_NUM
LEFT JOIN SCENE SC ON SC.SI_NUM = R.SI_NUM
WHERE R.SI_NUM = :si_num
GROUP BY R.RE_DIR
ORDER BY R.RE_DIR;
