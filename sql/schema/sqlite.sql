-- The SQLite schema of a gaz database, version 7: generated from gaz_cli/results/schema.py's metadata by
-- gaz_cli.results.sqlite.generated_schema() (tests/test_sqlite_writer.py keeps it equal)

CREATE TABLE IF NOT EXISTS particule (
	pa_num INTEGER NOT NULL, 
	pa_nom VARCHAR(64) NOT NULL, 
	pa_m FLOAT NOT NULL, 
	pa_r FLOAT NOT NULL, 
	PRIMARY KEY (pa_num)
);

CREATE TABLE IF NOT EXISTS schema_version (
	sv_version INTEGER NOT NULL
);

CREATE TABLE IF NOT EXISTS simulation (
	si_num INTEGER NOT NULL, 
	si_deb DATETIME NOT NULL, 
	si_dur FLOAT NOT NULL, 
	si_dim INTEGER NOT NULL, 
	si_n INTEGER NOT NULL, 
	si_l FLOAT NOT NULL, 
	PRIMARY KEY (si_num)
);

CREATE TABLE IF NOT EXISTS choc (
	si_num INTEGER NOT NULL, 
	ch_num INTEGER NOT NULL, 
	ch_t FLOAT NOT NULL, 
	ch_i INTEGER NOT NULL, 
	ch_j INTEGER NOT NULL, 
	ch_imp FLOAT NOT NULL, 
	PRIMARY KEY (si_num, ch_num), 
	FOREIGN KEY(si_num) REFERENCES simulation (si_num)
);

CREATE TABLE IF NOT EXISTS composition (
	si_num INTEGER NOT NULL, 
	pa_num INTEGER NOT NULL, 
	co_n INTEGER NOT NULL, 
	co_rank INTEGER, 
	PRIMARY KEY (si_num, pa_num), 
	FOREIGN KEY(si_num) REFERENCES simulation (si_num), 
	FOREIGN KEY(pa_num) REFERENCES particule (pa_num)
);

CREATE TABLE IF NOT EXISTS profil (
	si_num INTEGER NOT NULL, 
	pr_axis INTEGER NOT NULL, 
	pr_block INTEGER NOT NULL, 
	pr_bin INTEGER NOT NULL, 
	pr_samples INTEGER NOT NULL, 
	pr_count INTEGER NOT NULL, 
	PRIMARY KEY (si_num, pr_axis, pr_block, pr_bin), 
	FOREIGN KEY(si_num) REFERENCES simulation (si_num)
);

CREATE TABLE IF NOT EXISTS rebond (
	si_num INTEGER NOT NULL, 
	re_num INTEGER NOT NULL, 
	pa_num INTEGER NOT NULL, 
	re_t FLOAT NOT NULL, 
	re_dir INTEGER NOT NULL, 
	re_vit FLOAT NOT NULL, 
	re_vp FLOAT NOT NULL, 
	PRIMARY KEY (si_num, re_num), 
	FOREIGN KEY(si_num) REFERENCES simulation (si_num), 
	FOREIGN KEY(pa_num) REFERENCES particule (pa_num)
)
 WITHOUT ROWID;

CREATE TABLE IF NOT EXISTS resultat (
	si_num INTEGER NOT NULL, 
	rs_events BIGINT NOT NULL, 
	rs_bounces BIGINT NOT NULL, 
	rs_collisions BIGINT NOT NULL, 
	rs_ke_start FLOAT NOT NULL, 
	rs_ke_end FLOAT NOT NULL, 
	rs_virial FLOAT NOT NULL, 
	rs_wall_time FLOAT NOT NULL, 
	PRIMARY KEY (si_num), 
	FOREIGN KEY(si_num) REFERENCES simulation (si_num)
);

CREATE TABLE IF NOT EXISTS scene (
	si_num INTEGER NOT NULL, 
	sc_seed BIGINT NOT NULL, 
	sc_temperature FLOAT NOT NULL, 
	sc_engine VARCHAR(32) NOT NULL, 
	sc_boundary VARCHAR(16) NOT NULL, 
	sc_gravity FLOAT NOT NULL, 
	sc_restitution FLOAT NOT NULL, 
	sc_tc FLOAT NOT NULL, 
	sc_wall_restitution FLOAT NOT NULL, 
	sc_dt FLOAT, 
	sc_drag FLOAT NOT NULL, 
	sc_pair_gravity FLOAT NOT NULL, 
	sc_placement VARCHAR(16) NOT NULL, 
	sc_record VARCHAR(16) NOT NULL, 
	sc_version VARCHAR(16) NOT NULL, 
	sc_file TEXT, 
	PRIMARY KEY (si_num), 
	FOREIGN KEY(si_num) REFERENCES simulation (si_num)
);

INSERT INTO schema_version (sv_version) VALUES (7);
