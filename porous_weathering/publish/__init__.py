"""Publishing weathered states: PBR textures baked from the weathered materials, one glTF 2.0
file with a material variant per state, and its paradata. One module per job:

- ``export``: the options, the states, the steps and checks, and the orchestration
  (``export_variants``, ``iter_export``): the documented ``porous_weathering.export``;
- ``mapping``: the PBR mapping maths (``pbr_from_weights``, the sRGB curve, 8-bit texel codes),
  plain numpy without bpy;
- ``textures``: the texture bakes: the UV map, the bake materials and their Emission probe, the
  textures and PBR materials of the baked weights;
- ``gltf``: writing the glTF: the copies finished for the .glb, the material variants, Blender's
  glTF add-on;
- ``paradata``: the paradata sidecar, the .glb's sha256 and the versions it records.

May import: bpy, ``core``, ``common``, ``blender``, ``shading`` and ``maps`` (``mapping``: numpy only).
"""
