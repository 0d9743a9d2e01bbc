"""How neighbours are found: line order in 1D (:mod:`.line`); in 2D/3D cells with
crossing events (:mod:`.cells`), a fine and a coarse grid for mixtures of very different
sizes (:mod:`.classes`), for dense fluids neighbour lists (:mod:`.lists`), for dilute
gases in a box with walls a scan of every particle (:mod:`.dilute`)."""
