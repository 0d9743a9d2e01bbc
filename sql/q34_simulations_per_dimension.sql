-- Q34: number of simulations for each dimension of space.
SELECT SI_DIM, COUNT(*) AS NB_SIMULATIONS
FROM SIMULATION
GROUP BY SI_DIM
ORDER BY SI_DIM;
