"""How neighbours are found: line order in 1D (:mod:`.line`); in 2D/3D cells with
crossing events (:mod:`.cells`) or, for dense fluids, neighbour lists (:mod:`.lists`)."""
