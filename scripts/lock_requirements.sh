#!/usr/bin/env bash
# Regenerate requirements.lock (`make lock`): resolve requirements.txt in a fresh virtual environment, with
# torch installed first as `make venv` does, and write every installed distribution's exact version except
# torch (its build differs between CPU, CUDA and Colab; TORCH_SPEC pins it) and the package itself.
set -euo pipefail
repo_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
python3_bin=${PYTHON3:-python3}
torch_spec=${TORCH_SPEC:-torch==2.13.0}
work_dir=$(mktemp -d "${TMPDIR:-/tmp}/hoi_lock.XXXXXX")
trap 'rm -rf "$work_dir"' EXIT
"$python3_bin" -m venv "$work_dir/venv"
py="$work_dir/venv/bin/python"
"$py" -m pip install --quiet "$torch_spec" ${TORCH_INDEX_URL:+--extra-index-url "$TORCH_INDEX_URL"}
"$py" -m pip install --quiet -r "$repo_root/requirements.txt"
{
  echo "# Exact versions of everything requirements.txt resolves to, as CI and \`make venv\` install it"
  echo "# (a constraints file: pip install -r requirements.txt -c requirements.lock). Regenerate with"
  echo "# \`make lock\`; requirements.txt keeps the lower bounds a Colab runtime installs against."
  echo "# Python $("$py" -c 'import platform; print(platform.python_version())'); torch is pinned by TORCH_SPEC instead."
  "$py" -m pip freeze --exclude-editable | grep -v -i -E '^(torch|nvidia-[a-z0-9_-]+|triton|hoi[-_]tutorial)==' | LC_ALL=C sort -f
} > "$repo_root/requirements.lock"
echo "wrote requirements.lock ($(grep -c '==' "$repo_root/requirements.lock") pins)"
