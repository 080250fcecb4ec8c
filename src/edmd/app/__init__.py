"""The application: configuration files (:mod:`.config`), run directories (:mod:`.runner`), the
``edmd`` command (:mod:`.cli`), figures and movies (:mod:`.plots`, :mod:`.movie`,
:mod:`.tableplot`), ahead-of-time compilation (:mod:`.precompile`) and parameter sweeps
(:mod:`.sweeps`)."""
