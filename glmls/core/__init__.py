"""The numpy-only core: settings (:mod:`.config`), the registry of weights (:mod:`.weights`),
handles and their scaling (:mod:`.handles`), the mesh lattice of an image (:mod:`.mesh`) and
the float64 reference of the mathematics (:mod:`.reference`). Nothing here touches OpenGL."""
