#!/usr/bin/env bash
# Open a shipid report page in Debian's headless Chromium, as a person would, and check what it shows.
#
#   .ci/browser-check.sh REPORT.html SCREENSHOT.png EXPECTED_CASE_IDS_FILE [MIN_FIGURES]
#
# - the shipped page must hold no <script> and load nothing from elsewhere;
# - SCREENSHOT.png: the page at 1400×2000 (look at it);
# - a copy of the page with a small measuring script appended is rendered and its DOM dumped; the
#   script writes each <figure>'s SVG size (getBoundingClientRect; 0 × 0 when it is not shown, e.g.
#   inside a closed <details>) and the case ids of the summary
#   table's rows (`table.summary tr[data-case-id]`) into the DOM. Fails when a case id of
#   EXPECTED_CASE_IDS_FILE (one per line; blank lines ignored) is not in the summary table, when a
#   figure's SVG has zero width or height, or when there are fewer than MIN_FIGURES figures (default 0).
#
# Without /usr/bin/chromium (CHROMIUM overrides the path) it prints a SKIPPED notice and exits 0, unless
# SHIPID_REQUIRE_BROWSER=1, when it fails. Install it with `apt-get install -y chromium`.
set -euo pipefail

if [ $# -lt 3 ] || [ $# -gt 4 ]; then
    echo "usage: $0 REPORT.html SCREENSHOT.png EXPECTED_CASE_IDS_FILE [MIN_FIGURES]" >&2
    exit 2
fi
report=$1 screenshot=$2 expected=$3 min_figures=${4:-0}
chromium=${CHROMIUM:-/usr/bin/chromium}

if [ ! -x "$chromium" ]; then
    if [ "${SHIPID_REQUIRE_BROWSER:-0}" = 1 ]; then
        echo "browser check FAILED: $chromium is missing and SHIPID_REQUIRE_BROWSER=1 (apt-get install -y chromium)" >&2
        exit 1
    fi
    echo "SKIPPED browser check of $report: $chromium is missing (apt-get install -y chromium; SHIPID_REQUIRE_BROWSER=1 makes this fail)"
    exit 0
fi
[ -f "$report" ] || { echo "browser check FAILED: no file $report" >&2; exit 1; }
[ -f "$expected" ] || { echo "browser check FAILED: no file $expected" >&2; exit 1; }

failures=0
fail() { echo "browser check FAILED: $*" >&2; failures=$((failures + 1)); }

# The shipped page stays script-free and self-contained.
if grep -qi '<script' "$report"; then fail "$report holds a <script> element"; fi
if grep -Eqi '(src|href)="(https?:|//)' "$report"; then fail "$report refers to an external resource"; fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

run_chromium() { # profile-name, then chromium arguments
    local profile=$work/profile-$1
    shift
    mkdir -p "$profile"
    timeout 180 "$chromium" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
        --disable-background-networking --disable-component-update --disable-sync \
        --user-data-dir="$profile" "$@"
}

abs_report=$(cd "$(dirname "$report")" && pwd)/$(basename "$report")
mkdir -p "$(dirname "$screenshot")"
abs_screenshot=$(cd "$(dirname "$screenshot")" && pwd)/$(basename "$screenshot")
rm -f "$abs_screenshot"
run_chromium shot --window-size=1400,2000 --screenshot="$abs_screenshot" "file://$abs_report" \
    >"$work/shot.log" 2>&1 || true
if [ ! -s "$abs_screenshot" ]; then
    fail "no screenshot written (chromium said: $(tail -n 5 "$work/shot.log" | tr '\n' ' '))"
fi

# The copy with the measuring script (after </html> the parser still puts it at the end of <body>).
copy=$work/measured.html
cp "$report" "$copy"
cat >>"$copy" <<'JS'
<script>
(function () {
  var lines = [];
  document.querySelectorAll('figure').forEach(function (f, i) {
    var s = f.querySelector('svg');
    // An SVG that is not shown (in a closed <details>, display:none) counts as 0 × 0.
    var shown = s && (!s.checkVisibility || s.checkVisibility({ visibilityProperty: true }));
    var r = shown ? s.getBoundingClientRect() : { width: 0, height: 0 };
    lines.push('FIGURE\t' + (f.getAttribute('data-file') || ('#' + i)) + '\t' +
      r.width.toFixed(1) + '\t' + r.height.toFixed(1));
  });
  document.querySelectorAll('table.summary tr[data-case-id]').forEach(function (tr) {
    lines.push('CASE\t' + tr.getAttribute('data-case-id'));
  });
  var out = document.createElement('pre');
  out.id = 'shipid-measure';
  out.textContent = 'BEGIN\n' + lines.join('\n') + '\nEND';
  document.body.appendChild(out);
})();
</script>
JS
run_chromium dom --window-size=1400,2000 --dump-dom "file://$copy" >"$work/dom.html" 2>"$work/dom.log" || true

# The measurements, unescaped (textContent is dumped with &, <, > escaped).
sed -n '/<pre id="shipid-measure">BEGIN/,/^END<\/pre>/p' "$work/dom.html" \
    | sed -e 's/&lt;/</g' -e 's/&gt;/>/g' -e 's/&quot;/"/g' -e 's/&amp;/\&/g' >"$work/measure.txt"
if ! grep -q '^END' "$work/measure.txt"; then
    fail "the measuring script's output is not in the dumped DOM (chromium said: $(tail -n 5 "$work/dom.log" | tr '\n' ' '))"
    exit 1
fi
grep -P '^CASE\t' "$work/measure.txt" | cut -f2- >"$work/cases.txt" || true
grep -P '^FIGURE\t' "$work/measure.txt" >"$work/figures.txt" || true

n_figures=$(wc -l <"$work/figures.txt")
while IFS=$'\t' read -r _ name width height; do
    if ! awk -v w="$width" -v h="$height" 'BEGIN { exit !(w > 0 && h > 0) }'; then
        fail "figure $name is rendered ${width}×${height}"
    fi
done <"$work/figures.txt"
if [ "$n_figures" -lt "$min_figures" ]; then
    fail "$n_figures figures on the page, expected at least $min_figures"
fi

n_expected=0
missing=0
while IFS= read -r id || [ -n "$id" ]; do
    [ -z "$id" ] && continue
    n_expected=$((n_expected + 1))
    if ! grep -qxF -- "$id" "$work/cases.txt"; then
        fail "case $id is not in the summary table"
        missing=$((missing + 1))
    fi
done <"$expected"

echo "browser check of $report: $(wc -l <"$work/cases.txt") case rows in the summary table," \
    "$((n_expected - missing)) of $n_expected expected case ids found, $n_figures figures" \
    "(smallest $(sort -t$'\t' -k3,3g "$work/figures.txt" | head -n1 | cut -f3,4 | tr '\t' x || true) px);" \
    "screenshot $abs_screenshot"
if [ "$failures" -gt 0 ]; then
    exit 1
fi
