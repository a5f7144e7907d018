"""The construction of deformed images: one :class:`~.pipeline.WarpPipeline` per context, the
compute scan conversion of the quads (:mod:`.cells`), the GL rasterizer (:mod:`.raster`), the
backward map (:mod:`.inverse`), and the images on their way in and out (:mod:`.source`)."""
