-- First and last RE_NUM of one simulation's wall bounces (si_num); NULL, NULL without any. Two primary-key lookups.
SELECT (SELECT MIN(R.RE_NUM) FROM REBOND R WHERE R.SI_NUM = :si_num) AS FIRST_RE_NUM,
       (SELECT MAX(R.RE_NUM) FROM REBOND R WHERE R.SI_NUM = :si_num) AS LAST_RE_NUM;
