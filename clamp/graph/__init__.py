"""The planning problem over joint states: the factor families of :mod:`clamp.factors` on a
(T, 2n) state array (:mod:`.problem`), and its GTSAM face: keys (:mod:`.keys`) and the
CustomFactor adapter (:mod:`.gtsam_adapter`)."""
