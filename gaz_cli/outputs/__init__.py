"""Files besides the database: trajectories, one module per format (:mod:`.h5md`,
:mod:`.gsd`, :mod:`.vtk`, registered in :mod:`.trajectory`), and animations
(:mod:`.animate`). This ``__init__`` imports nothing.
"""
