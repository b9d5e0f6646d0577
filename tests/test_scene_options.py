"""Scene options are declared once (config.options.OPTIONS); every user derives from the table."""

from __future__ import annotations

from dataclasses import fields

import pytest

from signatelec.config.options import OPTION_TABLE, OPTIONS
from signatelec.config.scene import SECTIONS, Effects, Scene, SceneError
from signatelec.engines.dem.spec import KERNEL_OPTIONS, KernelSpec


def test_the_dataclasses_hold_exactly_the_options_with_their_defaults():
    declared = {
        (section, f.name): f.default
        for section, cls in SECTIONS.items()
        for f in fields(cls)
        if (section, f.name) in OPTION_TABLE
    }
    assert declared == {(o.section, o.name): o.default for o in OPTIONS}
    for option in OPTIONS:
        assert option.default in option.values
        assert option.off is None or option.off in option.values
        assert option.description and "\n" not in option.description
    # the effects are physics: each names a model and the kernel is compiled per model, but
    # for the lubricated contacts, computed from the recorded kinematics after the run
    assert {f.name for f in fields(Effects)} == {o.name for o in OPTIONS if o.section == "effects"}
    assert all(not o.switch for o in OPTIONS if o.section == "effects")
    effects = [o for o in OPTIONS if o.section == "effects"]
    assert {o.name for o in effects if not o.kernel} == {"lubrication"}


@pytest.mark.parametrize(
    ("name", "on", "off"),
    [
        ("cage", "balls", "none"),
        ("friction", "coulomb", "none"),
        ("damping", "critical", "none"),
        ("gravity", "standard", "none"),
        ("centrifugal", "inertial", "compensated"),
    ],
)
def test_true_and_false_name_the_default_and_the_null_model(name, on, off):
    assert Scene.from_dict({"effects": {name: True}}).effects == Effects(**{name: on})
    assert Scene.from_dict({"effects": {name: False}}).effects == Effects(**{name: off})
    assert getattr(Effects(**{name: False}), name) == off
    assert getattr(Scene().with_overrides(**{name: False}).effects, name) == off


def test_model_choices_without_a_null_model_refuse_booleans():
    with pytest.raises(SceneError, match=r"effects.contact_law = True: must be one of hertz"):
        Scene.from_dict({"effects": {"contact_law": True}})
    with pytest.raises(SceneError, match=r"effects.tangential = 'none': must be one of seed"):
        Scene(effects=Effects(tangential="none"))


def test_switches_moved_out_of_effects_are_named_where_they_are_now():
    with pytest.raises(SceneError, match=r"effects.spin_up = False: unknown key.*\[procedure\]"):
        Scene.from_dict({"effects": {"spin_up": False}})
    scene = Scene.from_dict({"procedure": {"spin_up": False}, "outputs": {"energy": True}})
    assert scene.procedure.spin_up is False and scene.outputs.energy is True
    assert Scene.from_dict(scene.to_dict()) == scene


def test_the_kernel_spec_reads_every_kernel_option_and_nothing_else():
    assert [o.name for o in KERNEL_OPTIONS] == [name for name, _ in KernelSpec.default().choices]
    scene = Scene().with_overrides(
        cage="none", friction="none", energy=True, integrator="euler", electrical=False
    )
    spec = KernelSpec.from_scene(scene)
    assert spec["cage"] == "none" and spec["energy"] is True and spec["integrator"] == "euler"
    flags = spec.flags()
    assert flags["CAGE_NONE"] and not flags["CAGE_BALLS"] and flags["INTEGRATOR_EULER"]
    assert flags["ENERGY"] and flags["FRICTION_NONE"]
    # outputs that do not change the kernel share it
    assert KernelSpec.from_scene(scene.with_overrides(electrical=True)) == spec
    with pytest.raises(ValueError, match="cage = 'spokes'"):
        KernelSpec(tuple((n, "spokes" if n == "cage" else v) for n, v in spec.choices))
