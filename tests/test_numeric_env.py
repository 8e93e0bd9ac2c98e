"""scripts/numeric_env.py: the kernels in use, and an environment that selects others (what CI's second pass uses)."""
import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "numeric_env.py"
spec = importlib.util.spec_from_file_location("numeric_env", SCRIPT)
numeric_env = importlib.util.module_from_spec(spec)
spec.loader.exec_module(numeric_env)


def _found(openblas, torch_capability, machine="x86_64"):
    return {"openblas": openblas, "torch": torch_capability, "mkl_cbwr": "(unset)", "machine": machine}


def test_the_other_environment_differs_from_the_machines_kernels():
    env = numeric_env.other_environment(_found(["SkylakeX (libscipy_openblas)"], "AVX512"))
    assert env == {"MKL_CBWR": "COMPATIBLE", "OPENBLAS_CORETYPE": "Haswell", "ATEN_CPU_CAPABILITY": "avx2"}
    env = numeric_env.other_environment(_found(["Haswell (libscipy_openblas)"], "AVX2"))
    assert env["OPENBLAS_CORETYPE"] == "Sandybridge" and env["ATEN_CPU_CAPABILITY"] == "default"
    env = numeric_env.other_environment(_found(["Zen (libscipy_openblas)"], "DEFAULT"))
    assert env["OPENBLAS_CORETYPE"] == "Sandybridge" and env["ATEN_CPU_CAPABILITY"] == "avx2"
    env = numeric_env.other_environment(_found(["Prescott (libscipy_openblas)"], "AVX2"))
    assert env["OPENBLAS_CORETYPE"] == "Core2"                   # nothing older: the next one up


def test_other_machines_and_unknown_cores_change_only_what_they_can():
    env = numeric_env.other_environment(_found(["NEOVERSEN1 (libscipy_openblas)"], "NO AVX", machine="aarch64"))
    assert env == {"MKL_CBWR": "COMPATIBLE"}
    assert "OPENBLAS_CORETYPE" not in numeric_env.other_environment(_found(["(threadpoolctl not installed)"], "AVX2"))


def test_the_kernels_in_use_are_read(capsys):
    assert numeric_env.main(["--show"]) == 0
    assert "numeric kernels: OpenBLAS" in capsys.readouterr().out
    assert numeric_env.main(["--other"]) == 0
    assert "export MKL_CBWR=COMPATIBLE" in capsys.readouterr().out
