"""How neighbours are found: line order in 1D (:mod:`.line`); in 2D/3D cells with
crossing events (:mod:`.cells`), for dense fluids neighbour lists (:mod:`.lists`), for
dilute gases in a box with walls a scan of every particle (:mod:`.dilute`)."""
