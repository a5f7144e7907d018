"""The numerical analysis of section 5 of the paper and its pictures: the error field
(:mod:`.field`) and its statistics (:mod:`.stats`), reference-triangle errors
(:mod:`.triangles`), fold-overs (:mod:`.foldovers`), colour maps, offscreen pictures
(:mod:`.canvas`, :mod:`.pictures`), the report and the automatic choice (:mod:`.tune`)."""
