"""The 3D talking-head community's outputs as conditions: vertex sequences and FLAME.

Readers of the layouts FaceFormer, CodeTalker, SelfTalk, UniTalker, EMOTE and DiffPoseTalk write
(:mod:`~app.stimuli.meshes.vertexfile`, :mod:`~app.stimuli.meshes.meshfile`,
:mod:`~app.stimuli.meshes.flameparams`), FLAME's forward model with the user's own model file
(:mod:`~app.stimuli.meshes.flame`; never shipped; its pickles read as data only,
:mod:`~app.stimuli.meshes.pickles`), the sequence every reader produces
(:mod:`~app.stimuli.meshes.sequence`), where the lips and the eyes are
(:mod:`~app.stimuli.meshes.regions`), the mesh as a condition's track
(:mod:`~app.stimuli.meshes.source`), the eyes beside a mesh (:mod:`~app.stimuli.meshes.fairness`)
and the field's metrics, LVE and FDD (:mod:`~app.stimuli.meshes.metrics`,
:mod:`~app.stimuli.meshes.summary`). No GL here: the renderer draws them
(:mod:`renderer.meshface`). See docs/reference/meshes.md.
"""
