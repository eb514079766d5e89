"""What a scene file says: :mod:`.spec` reads and checks a scene (``harness/scenes/*.toml``) into a
:class:`~harness.scene.spec.Scene`; :mod:`.schema` holds the TOML checks shared with sweep files,
:mod:`.expressions` the checked expressions of checks and metrics, :mod:`.profiles` the input
profiles, :mod:`.recording` how much a run records (and the refusal of one that would not fit).

May import: :mod:`harness.common` and :mod:`spurdiff`. Nothing here runs an FMU.
"""
