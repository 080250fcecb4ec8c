"""Files a run writes and reads: checkpoints (:mod:`.checkpoint`), GSD trajectories
(:mod:`.trajectory`), thermo tables (:mod:`.thermo`), exports (:mod:`.export`), all written
atomically (:mod:`.atomic`)."""
