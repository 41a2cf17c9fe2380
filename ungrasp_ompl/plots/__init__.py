"""The pictures (PNG, matplotlib): the C-space map and a plan in it (``cspace``), a plan's cage
profile (``cage_profile``), a tiled layout (``layout``), simulated trials (``trials``), and what
they and the campaigns' pictures share (``common``). Each ``*_figure`` returns a Figure; each
``draw_*`` writes it."""

__all__: list[str] = []  # nothing public: the workflows' results write their pictures
