"""The run machinery: :class:`~.simulation.Simulation` and its :class:`~.engine.Engine` (which
drives the compiled event loop), observers (:mod:`.observer`), updaters (:mod:`.updaters`), the
force-based reference MD (:mod:`.dem`) and memory estimates (:mod:`.memory`)."""
