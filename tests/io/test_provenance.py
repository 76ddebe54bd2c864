"""Provenance: the CPU by name, the usable cores, and the exact command for "Reproduce with"."""

import os
import platform
import shlex

from harness.io import provenance as prov


def test_command_line_is_the_exact_shell_quoted_command():
    argv = ["stress", "--variants", "stiff spring,heavy_top", "--quick", "--out-dir", "/tmp/a b"]
    line = prov.command_line(argv)
    assert line == "harness stress --variants 'stiff spring,heavy_top' --quick --out-dir '/tmp/a b'"
    assert shlex.split(line)[1:] == argv


def test_command_line_prefers_recorded_arguments(monkeypatch):
    monkeypatch.setattr(prov.sys, "argv", ["/usr/bin/harness", "validate", "--scenes", "torque_free"])
    assert prov.command_line() == "harness validate --scenes torque_free"
    prov.set_argv(["rolling-study", "--quick"])
    try:
        assert prov.command_line() == "harness rolling-study --quick"
    finally:
        prov.set_argv(None)
    assert prov.command_line() == "harness validate --scenes torque_free"


def test_cpu_model_names_the_cpu(monkeypatch):
    x86 = "processor\t: 0\nvendor_id\t: GenuineIntel\nmodel\t\t: 85\nmodel name\t: Intel(R) Xeon(R)  Gold 6230\n"
    assert prov.cpu_model(x86) == "Intel(R) Xeon(R) Gold 6230"
    board = "processor\t: 0\nBogoMIPS\t: 108.00\nHardware\t: BCM2835\nModel\t\t: Raspberry Pi 4 Model B\n"
    assert prov.cpu_model(board) == "BCM2835"
    monkeypatch.setattr(platform, "processor", lambda: "x86_64")
    assert prov.cpu_model("processor\t: 0\nmodel\t\t: 85\n") == "x86_64"
    monkeypatch.setattr(platform, "processor", lambda: "")
    assert prov.cpu_model("") == "unknown cpu"


def test_cpu_model_of_this_machine_matches_proc_cpuinfo():
    try:
        with open("/proc/cpuinfo") as f:
            names = [line.split(":", 1)[1].strip() for line in f if line.startswith("model name")]
    except OSError:
        names = []
    if names:
        assert prov.cpu_model() == " ".join(names[0].split())
    else:
        assert prov.cpu_model()


def test_cores_counts_usable_and_all():
    usable, word1, word2, total = prov.cores().split()
    assert (word1, word2) == ("usable", "of") and int(total) == os.cpu_count()
    assert 1 <= int(usable) <= len(os.sched_getaffinity(0))


def test_reports_are_stamped_with_the_load_at_the_end_of_the_run():
    from harness.io.provenance import made_with, provenance

    prov = provenance()
    assert float(prov["load"]) >= 0.0  # the 1-minute load average, as the OS gives it
    assert made_with(prov).endswith(f", load average {prov['load']} (1 min, at the end of the run)")
