-- Wall bounces of one simulation (si_num) per wall, species and time bin (bins equal windows of SI_DUR): count, sums of |v_perp|, |v| and |v_perp|^2.
SELECT R.RE_DIR,
       R.PA_NUM,
       FLOOR(R.RE_T * :bins / S.SI_DUR) AS BIN,
       COUNT(*) AS NB_REBONDS,
       SUM(R.RE_VP) AS SUM_VP,
       SUM(R.RE_VIT) AS SUM_VIT,
       SUM(R.RE_VP * R.RE_VP) AS SUM_VP2
FROM REBOND R
JOIN SIMULATION S ON S.SI_NUM = R.SI_NUM
WHERE R.SI_NUM = :si_num
GROUP BY R.RE_DIR, R.PA_NUM, FLOOR(R.RE_T * :bins / S.SI_DUR)
ORDER BY R.RE_DIR, R.PA_NUM, BIN;
