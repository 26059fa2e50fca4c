# Careless and hostile input to the CLI, its job files and its data: each case must be refused
# in one line naming the field or flag. Sourced by bench/probe.sh, which defines $FMUCAL,
# $WORK, $EX and probe_case NAME FIELD -- CMD ARGS...

in_dir="$WORK/input"
mkdir -p "$in_dir"
cp "$EX"/furuta/*.mat "$EX"/furuta/*.csv "$EX"/diagnose/data.csv "$in_dir"/ 2>/dev/null || true
cp "$EX/diagnose/data.csv" "$in_dir/diagnose_data.csv"

# in_job NAME EXAMPLE PERL-EXPR: writes $in_dir/NAME.toml, examples/EXAMPLE/job.toml edited by
# a perl substitution (the whole file is one string: -0777), and prints its path.
in_job() {
  local out="$in_dir/$1.toml" src="$EX/$2/job.toml"
  if [ "$2" = diagnose ]; then
    sed 's/path = "data.csv"/path = "diagnose_data.csv"/' "$src" | perl -0777 -pe "$3" > "$out"
  else
    perl -0777 -pe "$3" "$src" > "$out"
  fi
  printf '%s\n' "$out"
}

# The commands (arrays, not functions: probe_case runs its command under `timeout`).
in_calibrate=("$FMUCAL" calibrate --out "$in_dir/out")
in_diagnose=("$FMUCAL" diagnose --out "$in_dir/out-diagnose")

# Worker counts: a cap, and at least one.
j=$(in_job workers-many furuta 's/count = 2/count = 1000000/')
probe_case workers-count-huge workers.count -- "${in_calibrate[@]}" "$j" --workers 100000
probe_case workers-flag-huge --workers -- "${in_calibrate[@]}" "$EX/furuta/job.toml" --workers 100000
probe_case workers-flag-zero --workers -- "${in_calibrate[@]}" "$EX/furuta/job.toml" --workers 0
j=$(in_job workers-zero furuta 's/count = 2/count = 0/')
probe_case workers-count-zero workers.count -- "${in_calibrate[@]}" "$j"

# Paths that are not regular files.
j=$(in_job data-dev-zero furuta 's#path = "FurutaData.mat"#path = "/dev/zero"#')
probe_case data-dev-zero data.path -- "${in_calibrate[@]}" "$j"
probe_case data-dev-zero-diagnose data.path -- "${in_diagnose[@]}" "$j"
mkfifo "$in_dir/fifo.csv"
j=$(in_job data-fifo furuta 's#path = "FurutaData.mat"#path = "fifo.csv"#')
probe_case data-fifo data.path -- "${in_calibrate[@]}" "$j"
mkdir -p "$in_dir/folder.csv"
j=$(in_job data-folder furuta 's#path = "FurutaData.mat"#path = "folder.csv"#')
probe_case data-directory data.path -- "${in_calibrate[@]}" "$j"
j=$(in_job model-dev-zero furuta 's#path = "example:furuta"#path = "/dev/zero"#')
probe_case model-dev-zero model.path -- "${in_calibrate[@]}" "$j"
j=$(in_job model-folder furuta "s#path = \"example:furuta\"#path = \"$in_dir\"#")
probe_case model-directory model.path -- "${in_calibrate[@]}" "$j"
probe_case inspect-dev-zero "not a regular file" -- "$FMUCAL" inspect /dev/zero
probe_case job-file-dev-zero "job file" -- "${in_calibrate[@]}" /dev/zero
probe_case job-file-fifo "job file" -- "${in_diagnose[@]}" "$in_dir/fifo.csv"
j=$(in_job set-from-dev-zero furuta 's/\[simulation\]/[simulation]\nset_from = "\/dev\/zero"/')
probe_case set-from-dev-zero simulation.set_from -- "${in_calibrate[@]}" "$j"
probe_case simulate-input-fifo "not a regular file" -- "$FMUCAL" simulate example:decay --input "$in_dir/fifo.csv" -o "$in_dir/sim.csv"

# Mapping.
j=$(in_job inputs-twice furuta 's/(\[\[inputs\]\]\ncolumn = "u"\nvariable = "u"\n)/$1\[\[inputs\]\]\ncolumn = "phi"\nvariable = "u"\n/')
probe_case inputs-same-fmu-input 'inputs[1].variable' -- "${in_calibrate[@]}" "$j"
j=$(in_job outputs-twice furuta 's/(\[\[outputs\]\]\nvariable = "pendulumJoint.phi"\ncolumn = "theta"\n)/$1$1/')
probe_case outputs-twice 'outputs[2]' -- "${in_calibrate[@]}" "$j"

# The validation window, alike in calibrate and diagnose.
for v in 10.0 nan inf; do
  j=$(in_job "validation-$v" diagnose "s/validation_stop_time = 20.0/validation_stop_time = $v/")
  probe_case "validation-stop-$v-calibrate" simulation.validation_stop_time -- "${in_calibrate[@]}" "$j"
  probe_case "validation-stop-$v-diagnose" simulation.validation_stop_time -- "${in_diagnose[@]}" "$j"
done
j=$(in_job stop-nan furuta 's/stop_time = 40.0/stop_time = nan/')
probe_case stop-time-nan simulation.stop_time -- "${in_calibrate[@]}" "$j"

# An objective that overflows says so (the field: what happened).
awk -F, 'NR == 1 { print; next } { print $1 "," (NR % 2 ? 1e308 : -1e308) "," $3 "," $4 }' \
  "$in_dir/diagnose_data.csv" > "$in_dir/overflow.csv"
j=$(in_job overflow diagnose 's/path = "diagnose_data.csv"/path = "overflow.csv"/; s/x_tol = 1e-5/x_tol = 1e-5\nmax_fevals = 30/; s/^\[diagnose\].*//ms')
probe_case data-overflow overflowed -- "${in_calibrate[@]}" "$j"

# Quoting: a 10 MB name and bidi/NUL characters come back bounded and escaped (the probe checks
# the field; the escaping is asserted by tests/hardening_input.rs).
j=$(in_job long-name furuta 's/name = "armFriction"/"name = \"" . ("p" x 10000000) . "\""/e')
probe_case name-10mb 'parameters[0].name' -- "${in_calibrate[@]}" "$j"
j=$(in_job bidi-name furuta 's/name = "armFriction"/name = "arm\\u0000\\u202EFriction"/')
probe_case name-nul-bidi 'u{202e}' -- "${in_calibrate[@]}" "$j"

# [diagnose] and effects.
j=$(in_job diagnose-bad-port diagnose 's/port = "armJoint.tauExt"/port = "armJoint.nope"/')
probe_case diagnose-bad-port 'diagnose.ports[0].port' -- "${in_diagnose[@]}" "$j"
j=$(in_job diagnose-port-own-signal diagnose 's/velocities = \["pendulumJoint.w"\]/velocities = ["pendulumJoint.tauExt"]/')
probe_case diagnose-port-own-signal 'diagnose.ports[1].velocities[0]' -- "${in_diagnose[@]}" "$j"
j=$(in_job diagnose-ambient-mechanical diagnose 's/(positions = \["armJoint.phi"\])/$1\nambient = 293.15/')
probe_case diagnose-ambient-mechanical 'diagnose.ports[0].ambient' -- "${in_diagnose[@]}" "$j"
j=$(in_job effect-port-own-signal diagnose 's/^\[diagnose\]$/[[effects]]\nkind = "viscous_damping"\nport = "pendulumJoint.tauExt"\nsignal = "pendulumJoint.tauExt"\nparameters = { c = { start = 0.0, lower = 0.0, upper = 0.1 } }\n[diagnose]/m')
probe_case effect-port-own-signal 'effects[0].signal' -- "${in_calibrate[@]}" "$j"

# Command-line values.
probe_case certs-host-empty --host -- "$FMUCAL" certs --out "$in_dir/certs" --host ''
probe_case certs-host-dotdot --host -- "$FMUCAL" certs --out "$in_dir/certs" --host '../../etc'
probe_case certs-host-300 --host -- "$FMUCAL" certs --out "$in_dir/certs" --host "$(printf 'a%.0s' $(seq 300))"
probe_case coordinator-ftp --coordinator -- "${in_calibrate[@]}" "$EX/furuta/job.toml" --coordinator ftp://example.org
probe_case worker-coordinator-ftp --coordinator -- "$FMUCAL" worker --coordinator ftp://example.org
probe_case health-url-ftp URL -- "$FMUCAL" health ftp://example.org
printf 'x\n' > "$in_dir/token-short"
probe_case token-one-char --token-file -- \
  "${in_calibrate[@]}" "$EX/furuta/job.toml" --coordinator http://127.0.0.1:9 --token-file "$in_dir/token-short"
probe_case token-dev-zero --token-file -- \
  "${in_calibrate[@]}" "$EX/furuta/job.toml" --coordinator http://127.0.0.1:9 --token-file /dev/zero

# The CLI side of the earlier hardening round: sizes past their caps and values no run can use.
j=$(in_job population-max furuta 's/algorithm = "nelder-mead"/algorithm = "differential-evolution"\npopulation = 18446744073709551615/')
probe_case population-2-64 optimizer.population -- "${in_calibrate[@]}" "$j"
j=$(in_job population-1e10 furuta 's/algorithm = "nelder-mead"/algorithm = "differential-evolution"\npopulation = 10000000000/')
probe_case population-1e10 optimizer.population -- "${in_calibrate[@]}" "$j"
j=$(in_job ga-population furuta 's/algorithm = "nelder-mead"/algorithm = "genetic"\npopulation = 100000000/')
probe_case ga-population-1e8 optimizer.population -- "${in_calibrate[@]}" "$j"
j=$(in_job max-iters furuta 's/f_tol = 1e-2/f_tol = 1e-2\nmax_iters = 18446744073709551615/')
probe_case max-iters-huge optimizer.max_iters -- "${in_calibrate[@]}" "$j"
j=$(in_job bounds-1e308 furuta 's/lower = 0.0\nupper = 0.022/lower = -1e308\nupper = 1e308/')
probe_case bounds-1e308 'parameters[0].lower' -- "${in_calibrate[@]}" "$j"
j=$(in_job tolerance-tiny furuta 's/tolerance = 1e-6/tolerance = 1e-300/')
probe_case tolerance-1e-300 simulation.tolerance -- "${in_calibrate[@]}" "$j"
j=$(in_job parameter-twice furuta 's/name = "pendulumFriction"/name = "armFriction"/')
probe_case parameter-twice 'parameters[1].name' -- "${in_calibrate[@]}" "$j"
awk -F, 'NR == 3 { print $1 ",inf," $3 "," $4; next } { print }' "$in_dir/diagnose_data.csv" > "$in_dir/inf.csv"
j=$(in_job data-inf diagnose 's/path = "diagnose_data.csv"/path = "inf.csv"/')
probe_case data-inf-cell 'data.columns[phi]' -- "${in_calibrate[@]}" "$j"

# A refused or failed local job leaves no --out folder behind (every case above wrote to these).
left_out="$(ls -d "$in_dir/out" "$in_dir/out-diagnose" 2>/dev/null | tr '\n' ' ')"
if [ -n "$left_out" ]; then
    report "refused jobs leave no --out folder" FAIL "left: $left_out"
else
    report "refused jobs leave no --out folder" PASS "no $in_dir/out, no out-diagnose"
fi

# A data file with a UTF-8 byte-order mark, as Excel writes it: the CLI reads it, and so does
# the Python client (from the repository's sources, with the suite's venv where it exists).
printf '\xef\xbb\xbf' > "$in_dir/bom.csv"
cat "$EX/friction/data.csv" >> "$in_dir/bom.csv"
j=$(in_job csv-bom friction 's#path = "data.csv"#path = "bom.csv"#')
probe_works csv-bom-cli -- "${in_calibrate[@]}" "$j"
in_py="$EX/../target/pyenv/bin/python"
if [ -x "$in_py" ]; then
  probe_works csv-bom-python -- "$in_py" -B -c '
import sys
from pathlib import Path
sys.path.insert(0, sys.argv[2])
from fmucal_client.tables import read_csv
t = read_csv(Path(sys.argv[1]), "time")
names = [n for n, _ in t.columns]
assert names == ["x"] and len(t.time) > 100, names
print("read", len(t.time), "rows; columns", names)' "$in_dir/bom.csv" "$EX/../clients/python/src"
fi
