-- The scene file of one simulation (SCENE.SC_FILE, TOML): run it again with gaz simulate FILE.toml. NULL for runs stored before schema version 3.
SELECT SI_NUM, SC_FILE
FROM SCENE
WHERE SI_NUM = :si_num;
