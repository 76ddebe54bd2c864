"""three_link_chain: no closed form.

The spatial three-link chain (``models/three_link_chain/``) is the worked example of a scene
without code: its system is read from its MJCF (``harness.model.from_model_file``), and it
declares only the checks that need no closed form (energy, joints, trajectory against the
in-house reference, reactions). This module exists because every scene has its module here;
it defines no ``exact_error``, so ``harness.measure.exact`` finds no exact check for it, as
for a copy of the folder under another name, which has no module at all.
"""
