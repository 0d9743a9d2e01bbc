-- Particle-particle collisions of one simulation (si_num, duration in s; CHOC: --record all) per time bin (bins equal windows) and pair of species: count and sum of the impulses |J| (kg.m/s).
-- CH_I and CH_J are particle indices (from 0); species of rank k (COMPOSITION.CO_RANK) own the k-th block of
-- indices, blocks in rank order with CO_N particles each. RANK_I, RANK_J: the two partners' species ranks, in
-- the order CHOC holds them (the reader adds (i, j) and (j, i)). No collision: one row of NULLs.
-- BIN = floor(CH_T * bins / duration), written CAST(x AS BIGINT), less 1 where that is above x: exact on both
-- backends (SQLite's CAST truncates, PostgreSQL's rounds half to even) without FLOOR, which SQLAlchemy's SQLite driver runs in Python.
WITH BLOCKS AS (
    SELECT A.CO_RANK,
           (SELECT COALESCE(SUM(B.CO_N), 0) FROM COMPOSITION B
            WHERE B.SI_NUM = A.SI_NUM AND B.CO_RANK < A.CO_RANK) AS LO,
           (SELECT SUM(B.CO_N) FROM COMPOSITION B
            WHERE B.SI_NUM = A.SI_NUM AND B.CO_RANK <= A.CO_RANK) AS HI
    FROM COMPOSITION A
    WHERE A.SI_NUM = :si_num
)
SELECT (CAST(C.CH_T * :bins / :duration AS BIGINT) - CASE WHEN CAST(C.CH_T * :bins / :duration AS BIGINT) > C.CH_T * :bins / :duration THEN 1 ELSE 0 END) AS BIN,
       BI.CO_RANK AS RANK_I,
       BJ.CO_RANK AS RANK_J,
       COUNT(C.CH_NUM) AS NB_CHOCS,
       SUM(C.CH_IMP) AS SUM_IMP
FROM SIMULATION S
LEFT JOIN CHOC C ON C.SI_NUM = S.SI_NUM
LEFT JOIN BLOCKS BI ON C.CH_I >= BI.LO AND C.CH_I < BI.HI
LEFT JOIN BLOCKS BJ ON C.CH_J >= BJ.LO AND C.CH_J < BJ.HI
WHERE S.SI_NUM = :si_num
GROUP BY (CAST(C.CH_T * :bins / :duration AS BIGINT) - CASE WHEN CAST(C.CH_T * :bins / :duration AS BIGINT) > C.CH_T * :bins / :duration THEN 1 ELSE 0 END), BI.CO_RANK, BJ.CO_RANK;
