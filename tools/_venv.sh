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
    # tools/demo asks for the demo's part of the lock only (LOCK_PART=demo):
    # the package, its pictures and nothing of the development tools. The
    # whole lock (tools/test) includes it, so either environment serves
    # the demo; tools/test completes a demo environment in place.
    full="$VENV/.installed-$(cat pyproject.toml requirements-lock.txt |
        cksum | cut -d' ' -f1)"
    demo="$VENV/.installed-demo-$(cat pyproject.toml requirements-demo.txt |
        cksum | cut -d' ' -f1)"
    if [ "${LOCK_PART:-all}" = demo ]; then
        lock=requirements-demo.txt
        stamp=$demo
        [ -e "$full" ] && stamp=$full
    else
        lock=requirements-lock.txt
        stamp=$full
    fi
    if [ ! -e "$stamp" ]; then
        # A line at least every 10 s while a step is silent (creating the
        # venv, pip resolving or unpacking): a first run is never mute.
        SECONDS=0
        ( while sleep 10; do
            echo "  ... still setting up ($SECONDS s)" >&2
        done ) &
        ticker=$!
        trap 'kill "$ticker" 2>/dev/null || true' EXIT
        if [ ! -e "$full" ] && [ ! -e "$demo" ]; then
            echo "setting up $VENV with $PYTHON from $lock" \
                "(first run only)..." >&2
            rm -rf "$VENV"
            echo "creating the virtual environment ($PYTHON -m venv)..." >&2
            "$PYTHON" -m venv "$VENV"
        else
            echo "adding the rest of $lock to $VENV..." >&2
        fi
        total=$(grep -c '^[A-Za-z0-9]' "$lock")
        echo "installing $total locked packages (a line each as it comes)..." >&2
        # pip is quiet when not on a terminal: say each package, numbered.
        "$VENV/bin/python" -m pip install --require-hashes --no-deps \
            --progress-bar off -r "$lock" 2>&1 |
            awk -v total="$total" '
                /^(Collecting|Processing) / {
                    name = $2; sub(/.*\//, "", name); sub(/(==|-[0-9]).*/, "", name)
                    n++; printf "  [%d/%d] %s\n", n, total, name; fflush()
                }
                /^Requirement already satisfied/ { n++ }
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
        kill "$ticker" 2>/dev/null || true
        trap - EXIT
        echo "set up in $SECONDS s" >&2
    fi
fi
