"""The blind benchmark of ``calibrax diagnose``: cases whose effect is withheld from the
diagnosis, made by a chosen truth backend or by an emulator of a shipped DEM design, diagnosed,
and scored against a labels file the diagnosis never reads (``calibrax diagnose-benchmark``)."""
