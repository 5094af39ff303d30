"""The chamber wall's law at run time: what pressure does to the wall's bending stiffness (:mod:`whisker_opt.wall.law`)
and the stored table it reads (:mod:`whisker_opt.wall.table`, made by the wall cell of :mod:`whisker_opt.wallcell`)."""
