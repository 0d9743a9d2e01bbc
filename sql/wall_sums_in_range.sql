-- Wall bounces of one simulation (si_num) numbered lo to hi (RE_NUM), summed per species and wall: count, sums of |v_perp|, |v| and |v_perp|^2 (m/s).
-- WALL_KEY = PA_NUM * 8 + RE_DIR + 4 (RE_DIR in -3..3). gaz analyse runs it once per time bin, lo..hi being the bin's
-- rows when RE_NUM follows time (found by bisection with lookup_bounce.sql): a GROUP BY of one bin's rows sorts
-- little, where bounce_bins.sql sorts the whole run. NB_OUTSIDE counts the rows with RE_T outside [t_lo, t_hi) (s):
-- the check that the range is the bin. NB_ODD counts the rows whose RE_T, RE_VP or RE_VIT is no number (x = x + 0 fails
-- for text or bytes, which SQLite keeps when edited by hand and SUM reads as 0; always 0 on PostgreSQL): gaz analyse
-- then checks the run's rows and names the value.
SELECT R.PA_NUM * 8 + R.RE_DIR + 4 AS WALL_KEY,
       COUNT(*) AS NB_REBONDS,
       COUNT(*) FILTER (WHERE R.RE_T < :t_lo OR R.RE_T >= :t_hi) AS NB_OUTSIDE,
       COUNT(*) FILTER (WHERE NOT (R.RE_T = R.RE_T + 0 AND R.RE_VP = R.RE_VP + 0 AND R.RE_VIT = R.RE_VIT + 0)) AS NB_ODD,
       SUM(R.RE_VP) AS SUM_VP,
       SUM(R.RE_VIT) AS SUM_VIT,
       SUM(R.RE_VP * R.RE_VP) AS SUM_VP2
FROM REBOND R
WHERE R.SI_NUM = :si_num AND R.RE_NUM BETWEEN :lo AND :hi
GROUP BY R.PA_NUM * 8 + R.RE_DIR + 4;
