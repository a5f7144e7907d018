"""The GPU MLS: the kernel that owns the handles on the GPU behind one upload path
(:mod:`.kernel`, with :mod:`.storage` and the spatial :mod:`.bins`), and the passes over f
(:mod:`.passes`: points and lattices; :mod:`.error_field`)."""
