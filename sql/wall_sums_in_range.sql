-- Wall bounces of one simulation (si_num) numbered lo to hi (RE_NUM) of species pa_num, summed per wall: count, sums of |v_perp|, |v| and |v_perp|^2 (m/s).
-- Columns NB_M3 ... SUM_VP2_P3: wall RE_DIR = -3 (M3) to +3 (P3). No GROUP BY, hence no sort: gaz analyse runs it once per
-- time bin, lo..hi being the bin's rows when RE_NUM follows time (found by bisection with lookup_bounce.sql), and checks it:
-- NB_ROWS counts every row of the range (all species and walls), NB_OUTSIDE those with RE_T outside [t_lo, t_hi) (s).
SELECT COUNT(*) AS NB_ROWS,
       COUNT(*) FILTER (WHERE R.RE_T < :t_lo OR R.RE_T >= :t_hi) AS NB_OUTSIDE,
       COUNT(*) FILTER (WHERE R.RE_DIR = -3 AND R.PA_NUM = :pa_num) AS NB_M3,
       SUM(R.RE_VP) FILTER (WHERE R.RE_DIR = -3 AND R.PA_NUM = :pa_num) AS SUM_VP_M3,
       SUM(R.RE_VIT) FILTER (WHERE R.RE_DIR = -3 AND R.PA_NUM = :pa_num) AS SUM_VIT_M3,
       SUM(R.RE_VP * R.RE_VP) FILTER (WHERE R.RE_DIR = -3 AND R.PA_NUM = :pa_num) AS SUM_VP2_M3,
       COUNT(*) FILTER (WHERE R.RE_DIR = -2 AND R.PA_NUM = :pa_num) AS NB_M2,
       SUM(R.RE_VP) FILTER (WHERE R.RE_DIR = -2 AND R.PA_NUM = :pa_num) AS SUM_VP_M2,
       SUM(R.RE_VIT) FILTER (WHERE R.RE_DIR = -2 AND R.PA_NUM = :pa_num) AS SUM_VIT_M2,
       SUM(R.RE_VP * R.RE_VP) FILTER (WHERE R.RE_DIR = -2 AND R.PA_NUM = :pa_num) AS SUM_VP2_M2,
       COUNT(*) FILTER (WHERE R.RE_DIR = -1 AND R.PA_NUM = :pa_num) AS NB_M1,
       SUM(R.RE_VP) FILTER (WHERE R.RE_DIR = -1 AND R.PA_NUM = :pa_num) AS SUM_VP_M1,
       SUM(R.RE_VIT) FILTER (WHERE R.RE_DIR = -1 AND R.PA_NUM = :pa_num) AS SUM_VIT_M1,
       SUM(R.RE_VP * R.RE_VP) FILTER (WHERE R.RE_DIR = -1 AND R.PA_NUM = :pa_num) AS SUM_VP2_M1,
       COUNT(*) FILTER (WHERE R.RE_DIR = 1 AND R.PA_NUM = :pa_num) AS NB_P1,
       SUM(R.RE_VP) FILTER (WHERE R.RE_DIR = 1 AND R.PA_NUM = :pa_num) AS SUM_VP_P1,
       SUM(R.RE_VIT) FILTER (WHERE R.RE_DIR = 1 AND R.PA_NUM = :pa_num) AS SUM_VIT_P1,
       SUM(R.RE_VP * R.RE_VP) FILTER (WHERE R.RE_DIR = 1 AND R.PA_NUM = :pa_num) AS SUM_VP2_P1,
       COUNT(*) FILTER (WHERE R.RE_DIR = 2 AND R.PA_NUM = :pa_num) AS NB_P2,
       SUM(R.RE_VP) FILTER (WHERE R.RE_DIR = 2 AND R.PA_NUM = :pa_num) AS SUM_VP_P2,
       SUM(R.RE_VIT) FILTER (WHERE R.RE_DIR = 2 AND R.PA_NUM = :pa_num) AS SUM_VIT_P2,
       SUM(R.RE_VP * R.RE_VP) FILTER (WHERE R.RE_DIR = 2 AND R.PA_NUM = :pa_num) AS SUM_VP2_P2,
       COUNT(*) FILTER (WHERE R.RE_DIR = 3 AND R.PA_NUM = :pa_num) AS NB_P3,
       SUM(R.RE_VP) FILTER (WHERE R.RE_DIR = 3 AND R.PA_NUM = :pa_num) AS SUM_VP_P3,
       SUM(R.RE_VIT) FILTER (WHERE R.RE_DIR = 3 AND R.PA_NUM = :pa_num) AS SUM_VIT_P3,
       SUM(R.RE_VP * R.RE_VP) FILTER (WHERE R.RE_DIR = 3 AND R.PA_NUM = :pa_num) AS SUM_VP2_P3
FROM REBOND R
WHERE R.SI_NUM = :si_num AND R.RE_NUM BETWEEN :lo AND :hi;
