"""OpenGL plumbing that knows nothing of MLS: contexts (:mod:`.context`), shader loading
(:mod:`.shaders`), the binding points (:mod:`.bindings`), cached GL objects
(:mod:`.resources`) and compute dispatches (:mod:`.dispatch`)."""
