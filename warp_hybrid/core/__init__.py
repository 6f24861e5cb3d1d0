"""The contracts every stage shares (pbrt-v4's ``base/`` beside its implementations).

Nothing here renders: these modules define what the stages hand each other, so a new
pass depends on ``core`` alone, never on the stage that produced its input.

* ``constants``: mathematical constants and the rules more than one stage applies.
* ``camera``: the kernel-side pinhole camera and *the* camera ray.
* ``scene_gpu``: the device scene structs (materials, textures, lights, dome) and the
  material flag bits kernels test.
* ``gbuffer``: the G-buffer channel table, from which allocation, clearing (the
  background record), the AOVs and the kernel-side structs are all generated.
* ``features``: the effects a scene needs, which select the compiled code.
* ``passes``: the render-pass interface and the explicit per-frame state.
"""
