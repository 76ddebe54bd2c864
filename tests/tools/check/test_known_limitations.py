"""The table of known importer limitations (``harness/tools/check/known_limitations.toml``): every
entry complete and detectable, MJCF attributes resolved through default classes as MuJoCo does, an
entry matched only at the versions it was verified on."""

from __future__ import annotations

from pathlib import Path

from harness.tools.check import known_limitations as kl

ROOT = Path(__file__).resolve().parents[3]


def test_every_entry_is_complete_and_has_its_detector():
    table = kl.table()
    assert len(table) >= 20 and len({e.id for e in table}) == len(table)
    for e in table:
        assert e.loaders and set(e.loaders) <= {"MuJoCo", "Pinocchio", "Drake", "PyBullet"}, e.id
        assert set(e.versions) == set(e.loaders), e.id   # a verified version for each loader it names
        assert e.format in ("MJCF", "URDF") and e.element and e.behaviour and e.workaround and e.quantities, e.id
        assert e.detect in kl.DETECTORS and e.brief and len(e.brief) < len(e.behaviour) + 1, e.id
    assert {e.detect for e in table} == set(kl.DETECTORS)   # no detector without an entry


def test_a_limitation_holds_at_the_versions_it_was_verified_on():
    (e,) = [x for x in kl.table() if x.id == "pinocchio-mjcf-default-geom-mass"]
    assert e.covers("Pinocchio", e.versions["Pinocchio"])
    assert not e.covers("Pinocchio", "99.0.0") and not e.covers("Drake", e.versions["Pinocchio"])


def test_attributes_resolve_through_default_classes(tmp_path):
    path = tmp_path / "m.xml"
    path.write_text("""<mujoco>
  <default><geom mass="3"/>
    <default class="light"><geom mass="0.5"/><default class="inner"/></default>
  </default>
  <worldbody>
    <body name="a" childclass="light"><geom name="g1" size="0.1"/><geom name="g2" size="0.1" class="main"/>
      <body name="b"><geom name="g3" size="0.1" class="inner"/><geom name="g4" size="0.1" mass="7"/></body></body>
  </worldbody>
</mujoco>""")
    els = kl.elements(path)
    mass = {e.attrs["name"]: kl.effective(path, i, "mass") for i, e in enumerate(els) if e.tag == "geom" and "name" in e.attrs}
    assert mass == {"g1": "0.5", "g2": "3", "g3": "0.5", "g4": "7"}


def test_the_readme_links_the_table():
    assert "harness/tools/check/known_limitations.toml" in (ROOT / "README.md").read_text()
