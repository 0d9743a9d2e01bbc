-- Pressure on each wall of one simulation (parameter si_num), in Pa (N/m^(D-1)):
-- the Q36 momentum, (1 + e_w) m |v_perp| per bounce (2 m |v_perp| for elastic walls), divided by
-- the simulated duration and by the wall's measure SI_L^(SI_DIM-1) (1 in 1D, a length in 2D, an area in 3D).
SELECT R.RE_DIR,
       COUNT(*) AS NB_REBONDS,
       SUM((1 + COALESCE(SC.SC_WALL_RESTITUTION, 1.0)) * P.PA_M / 1000.0 * R.RE_VP) AS QUANTITE_MOUVEMENT,
       SUM((1 + COALESCE(SC.SC_WALL_RESTITUTION, 1.0)) * P.PA_M / 1000.0 * R.RE_VP)
         / (S.SI_DUR * CASE S.SI_DIM WHEN 1 THEN 1.0
                                    WHEN 2 THEN S.SI_L
                                    ELSE S.SI_L * S.SI_L END) AS PRESSION
FROM REBOND R
JOIN PARTICULE P ON P.PA_NUM = R.PA_NUM
JOIN SIMULATION S ON S.SI_NUM = R.SI_NUM
LEFT JOIN SCENE SC ON SC.SI_NUM = R.SI_NUM
WHERE R.SI_NUM = :si_num
GROUP BY R.RE_DIR, S.SI_DUR, S.SI_DIM, S.SI_L
ORDER BY R.RE_DIR;
