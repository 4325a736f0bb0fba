#!/usr/bin/env bash
# GUI smoke test: MeshLab (from the private prefix) under Xvfb opens a scan reconstructed by
# the plugin; its Filters menu must list every PicoScan filter, and a screenshot is taken.
#   gui_smoke_test.sh PREFIX WORK_DIR [SCREENSHOT_COPY.png]
# The copy is only written when PICOSCAN_UPDATE_SCREENSHOT=1 (it lives in docs/images/).
set -euo pipefail
prefix=$1
work=$2
screenshot_copy=${3:-}
rm -rf "$work"
mkdir -p "$work"
cd "$work"

fail() { echo "FAIL: $*"; exit 1; }

# A reconstructed scan: the plugin simulates the demo part and keeps it as a coloured grid mesh.
cat > scan.mlx <<'XML'
<!DOCTYPE FilterScript>
<FilterScript>
 <filter name="PicoScan: Simulate Scan">
  <Param type="RichString" name="sceneFile" value=""/>
  <Param type="RichInt" name="partView" value="-1"/>
  <Param type="RichString" name="calibrationFile" value=""/>
  <Param type="RichInt" name="shifts" value="4"/>
  <Param type="RichInt" name="periodBits" value="4"/>
  <Param type="RichFloat" name="fullScale" value="220"/>
  <Param type="RichFloat" name="noise" value="1"/>
  <Param type="RichFloat" name="blur" value="0.7"/>
  <Param type="RichInt" name="seed" value="1"/>
  <Param type="RichString" name="saveCaptureFolder" value=""/>
  <Param type="RichBool" name="binaryOnly" value="false"/>
  <Param type="RichFloat" name="minContrast" value="15"/>
  <Param type="RichFloat" name="minModulation" value="4"/>
  <Param type="RichEnum" name="output" value="1" enum_cardinality="2"/>
  <Param type="RichInt" name="meshStep" value="2"/>
 </filter>
</FilterScript>
XML
xvfb-run -a "$prefix/bin/meshlabserver" -s scan.mlx -o scan.ply -m vc vn > server.log 2>&1 || { cat server.log; fail "meshlabserver"; }
[ -s scan.ply ] || fail "no scan.ply"

# A project turns the camera frame (y down, z forward) to MeshLab's (y up, looking along -z).
cat > scan.mlp <<'XML'
<!DOCTYPE MeshLabDocument>
<MeshLabProject>
 <MeshGroup>
  <MLMesh label="scan.ply" filename="scan.ply" visible="1">
   <MLMatrix44>
1 0 0 0 
0 -1 0 0 
0 0 -1 0 
0 0 0 1 
</MLMatrix44>
  </MLMesh>
 </MeshGroup>
 <RasterGroup/>
</MeshLabProject>
XML

# Read by the test-only menu report plugin in the prefix (not by the shipped plugin).
export PICOSCAN_MESHLAB_MENU_REPORT="$work/filters.txt"
export HOME="$work/home"  # MeshLab's settings stay in the work folder
mkdir -p "$HOME"
xvfb-run -a -s "-screen 0 1280x960x24" bash -c '
  "$0/bin/meshlab" scan.mlp > gui.log 2>&1 &
  pid=$!
  for _ in $(seq 90); do [ -s filters.txt ] && break; sleep 1; done
  sleep 6  # let the scan render
  import -window root screenshot.png || true
  kill $pid 2>/dev/null || true
  wait $pid 2>/dev/null || true
' "$prefix"

[ -s filters.txt ] || { cat gui.log; fail "MeshLab did not report its Filters menu"; }
expected=(
  "PicoScan: Reconstruct from Capture Set"
  "PicoScan: Simulate Scan"
  "PicoScan: Clean Scan"
  "PicoScan: Align Layers"
  "PicoScan: Fuse and Mesh"
  "PicoScan: Measure Sphere or Plane"
  "PicoScan: Save Views for Project"
  "PicoScan: Fit Cross-section"
)
listed=$(grep -c "/PicoScan: " filters.txt || true)
for name in "${expected[@]}"; do
  grep -q "/$name\$" filters.txt || fail "Filters menu lacks '$name'"
done
echo "Filters menu: $(wc -l < filters.txt) entries, $listed PicoScan entries:"
grep "/PicoScan: " filters.txt
[ "$listed" -eq "${#expected[@]}" ] || fail "expected ${#expected[@]} PicoScan entries, found $listed"

[ -s screenshot.png ] || fail "no screenshot"
# A blank or single-colour screen would mean nothing was drawn.
spread=$(convert screenshot.png -colorspace gray -format "%[fx:standard_deviation]" info:)
echo "screenshot: $work/screenshot.png, grey standard deviation $spread"
awk -v s="$spread" 'BEGIN { exit !(s > 0.05) }' || fail "screenshot looks blank (standard deviation $spread)"
if [ "${PICOSCAN_UPDATE_SCREENSHOT:-0}" = 1 ] && [ -n "$screenshot_copy" ]; then
  mkdir -p "$(dirname "$screenshot_copy")"
  cp screenshot.png "$screenshot_copy"
  echo "copied to $screenshot_copy"
fi
echo "PASS"
