-- The scene file of one simulation (SCENE.SC_FILE, TOML): run it again with gaz simulate FILE.toml. NULL for runs stored before schema version 3, or without a SCENE row (SIMULATION rows written by other software).
SELECT S.SI_NUM, SC.SC_FILE
FROM SIMULATION S
LEFT JOIN SCENE SC ON SC.SI_NUM = S.SI_NUM
WHERE S.SI_NUM = :si_num;
