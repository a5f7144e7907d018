"""The construction of deformed images: one :class:`~.pipeline.WarpPipeline` per context, the
compute scan conversion of the quads (:mod:`.quads`), the GL rasterizer (:mod:`.raster`), the
error-bounded adaptive mesh (:mod:`.adaptive`), the backward map and f's inverse at points
(:mod:`.inverse`), the images on their way in and out (:mod:`.source`), and what a warp builds
and how, as values (:mod:`.options`: :class:`~.options.WarpOptions`,
:class:`~.options.PipelineOptions`)."""
