"""The physics: collision rules and walls (:mod:`.collide`), soft contact laws (:mod:`.contact`),
eMD* (:mod:`.emdstar`) with its two-body solver (:mod:`.twobody`) and tables (:mod:`.tables`),
and the drivers that act through events (:mod:`.thermostats`). Each packs its parameters for the
compiled core (``edmd._core``)."""
