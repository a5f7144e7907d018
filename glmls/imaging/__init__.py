"""The construction of deformed images: one :class:`~.pipeline.WarpPipeline` per context, the
compute scan conversion of the quads (:mod:`.quads`), the GL rasterizer (:mod:`.raster`), the
error-bounded adaptive mesh (:mod:`.adaptive`), the backward map (:mod:`.inverse`), and the
images on their way in and out (:mod:`.source`)."""
