# Sourced by every example's run.sh: the lwrlab command, the Python it runs on, and the output folder.
#
#   source "$HERE/../environment.sh" PREFIX "${1:-}"
#
# sets LWRLAB (absolute path of the command: $LWRLAB or `lwrlab` on the PATH), PYTHON ($PYTHON, or
# the interpreter lwrlab runs on, else python3), OUT (the folder given, or a new temporary one named
# PREFIX.XXXXXX; absolute, created) and the function `absolute PATH` (PATH from the starting folder).
absolute() { if [[ "$1" == /* ]]; then echo "$1"; else echo "$PWD/$1"; fi; }
LWRLAB="$(command -v "${LWRLAB:-lwrlab}")" || { echo "lwrlab not found: set LWRLAB" >&2; exit 127; }
LWRLAB="$(absolute "$LWRLAB")"
PYTHON="${PYTHON:-$(sed -n '1s/^#!//p' "$LWRLAB")}"  # by default the interpreter lwrlab runs on
if [[ "$PYTHON" == */* ]]; then PYTHON="$(absolute "$PYTHON")"; fi
[[ -x "$PYTHON" ]] || PYTHON=python3
OUT="${2:-$(mktemp -d "${TMPDIR:-/tmp}/$1.XXXXXX")}"
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
