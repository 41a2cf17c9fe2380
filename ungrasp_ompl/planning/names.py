"""The planners that can be asked for by name: a light module (no OMPL), so the command line can
list them in its help without loading the planning stack."""

#: OMPL geometric planners that can be asked for by name.
PLANNERS = ("RRTstar", "InformedRRTstar", "SORRTstar", "BITstar", "AORRTC", "FMT", "BFMT",
            "RRT", "RRTConnect", "KPIECE1", "BKPIECE1", "LBKPIECE1", "PRM", "PRMstar")

#: The exact lattice search, usable as a planner by this name.
LATTICE = "lattice"
