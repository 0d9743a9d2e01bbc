-- One row per simulation, for studies across runs (gaz analyse --vs KEY): what each run
-- was (dimension, particles, box, duration, temperature asked, boundary, seed, species'
-- radius and mass) and what it measured: the momentum given to all walls (Q36's
-- (1 + e_w) m |v_perp| per bounce, kg m/s), bounces, collisions, the collision virial and the
-- kinetic energy at start and end (RESULTAT). Runs of one species only (a mixture
-- has no single radius): PA_R and PA_M are NULL for them. SC_RECORD: a run recorded with
-- record = "none" stored no bounce, so its MOMENTUM of 0 measures nothing.
-- Runs in the sqlite3 shell and psql as it is.
SELECT S.SI_NUM, S.SI_DIM, S.SI_N, S.SI_L, S.SI_DUR,
       SC.SC_TEMPERATURE, SC.SC_BOUNDARY, SC.SC_SEED, SC.SC_RECORD,
       CASE WHEN C.KINDS = 1 THEN C.PA_R END AS PA_R,
       CASE WHEN C.KINDS = 1 THEN C.PA_M END AS PA_M,
       COALESCE(B.MOMENTUM, 0) AS MOMENTUM,
       COALESCE(B.BOUNCES, 0) AS BOUNCES,
       R.RS_COLLISIONS, R.RS_VIRIAL, R.RS_KE_START, R.RS_KE_END
FROM SIMULATION S
JOIN SCENE SC ON SC.SI_NUM = S.SI_NUM
JOIN RESULTAT R ON R.SI_NUM = S.SI_NUM
JOIN (SELECT CO.SI_NUM, COUNT(*) AS KINDS, MAX(P.PA_R) AS PA_R, MAX(P.PA_M) / 1000.0 AS PA_M
      FROM COMPOSITION CO JOIN PARTICULE P ON P.PA_NUM = CO.PA_NUM
      GROUP BY CO.SI_NUM) C ON C.SI_NUM = S.SI_NUM
LEFT JOIN (SELECT RB.SI_NUM,
                  SUM((1 + COALESCE(SW.SC_WALL_RESTITUTION, 1.0)) * P.PA_M / 1000.0 * RB.RE_VP) AS MOMENTUM,
                  COUNT(*) AS BOUNCES
           FROM REBOND RB JOIN PARTICULE P ON P.PA_NUM = RB.PA_NUM
           LEFT JOIN SCENE SW ON SW.SI_NUM = RB.SI_NUM
           GROUP BY RB.SI_NUM) B ON B.SI_NUM = S.SI_NUM
ORDER BY S.SI_NUM;
