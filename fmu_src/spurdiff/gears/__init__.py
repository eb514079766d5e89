"""The gear set: involute geometry of the three meshes (:mod:`.geometry`), the tooth form from the
generating rack (:mod:`.generating`), the design checks (:mod:`.checks`), the pin layout and speed
ratios of a planet pair (:mod:`.layout`), the mesh phasing (:mod:`.phasing`), and :func:`.design.derive`,
which derives a gear table and runs every check.

May import: the core (:mod:`spurdiff.errors`, ``datafile``, ``numerics``). Nothing here knows the
locking law, the dynamics or the FMI layer.
"""
