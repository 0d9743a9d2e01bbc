-- The first wall bounce of one simulation (si_num) numbered re_num or more: its RE_NUM and time RE_T (s). One primary-key lookup.
SELECT R.RE_NUM, R.RE_T
FROM REBOND R
WHERE R.SI_NUM = :si_num AND R.RE_NUM >= :re_num
ORDER BY R.RE_NUM
LIMIT 1;
