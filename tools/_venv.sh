# Sourced by tools/test and tools/demo: create the virtual environment (once
# per lock) and install the package into it.
#
# Locked mode (default): every dependency comes from requirements-lock.txt,
# pinned and hash-checked, so every machine runs the same versions.
# Drift mode (FSW_LATEST=1, or `tools/test --latest`): a separate
# environment, .venv-latest, gets the newest versions pyproject.toml allows,
# so a break in a new release shows up before users hit it.
PYTHON=${PYTHON:-}
if [ -z "$PYTHON" ]; then
    for candidate in python3.11 python3.12 python3.13 python3; do
        if command -v "$candidate" >/dev/null 2>&1 &&
            "$candidate" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
            PYTHON=$candidate
            break
        fi
    done
fi
if [ -z "$PYTHON" ]; then
    echo "fsw-scheduler needs Python >= 3.11" >&2
    exit 2
fi
if [ "${FSW_LATEST:-0}" = 1 ]; then
    VENV=${VENV:-.venv-latest}
    echo "drift mode: installing the newest allowed versions into $VENV..." >&2
    [ -x "$VENV/bin/python" ] || "$PYTHON" -m venv "$VENV"
    "$VENV/bin/python" -m pip install --quiet --upgrade pip >&2
    "$VENV/bin/python" -m pip install --quiet --upgrade \
        --upgrade-strategy eager -e '.[all]' >&2
    "$VENV/bin/python" -m pip freeze --exclude-editable >&2
else
    VENV=${VENV:-.venv}
    stamp="$VENV/.installed-$(cat pyproject.toml requirements-lock.txt |
        cksum | cut -d' ' -f1)"
    if [ ! -e "$stamp" ]; then
        echo "setting up $VENV with $PYTHON from requirements-lock.txt" \
            "(first run only)..." >&2
        rm -rf "$VENV"
        "$PYTHON" -m venv "$VENV"
        total=$(grep -c '^[A-Za-z0-9]' requirements-lock.txt)
        echo "installing $total locked packages (a line each as it comes)..." >&2
        # pip is quiet when not on a terminal: say each package, numbered.
        "$VENV/bin/python" -m pip install --require-hashes --no-deps \
            --progress-bar off -r requirements-lock.txt 2>&1 |
            awk -v total="$total" '
                /^(Collecting|Processing) / {
                    name = $2; sub(/.*\//, "", name); sub(/(==|-[0-9]).*/, "", name)
                    n++; printf "  [%d/%d] %s\n", n, total, name; fflush()
                }
                /^(ERROR|error)/ { print; fflush() }
                /^Installing collected/ { print "  unpacking..."; fflush() }
            ' >&2
        [ "${PIPESTATUS[0]}" -eq 0 ] || exit 2
        # The package itself, with the locked setuptools and nothing else.
        echo "installing fsw-scheduler itself (editable)..." >&2
        "$VENV/bin/python" -m pip install --quiet --no-deps \
            --no-build-isolation -e . >&2
        "$VENV/bin/python" -m pip check >&2
        touch "$stamp"
    fi
fi
