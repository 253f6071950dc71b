"""A plan's stages: request (:mod:`.request`) -> model (:mod:`.pipeline`, :mod:`.assembly`,
:mod:`.initialisation`) -> solution -> posterior -> verdict (:mod:`.verdict`, with the
checks of :mod:`.targets`, :mod:`.clearance`, :mod:`.limit_report`), the result
(:mod:`.result`), the planner's entry points (:mod:`.planner`) and replanning
(:mod:`.replanning`)."""
