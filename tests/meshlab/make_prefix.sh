#!/usr/bin/env bash
# Builds a private MeshLab install in PREFIX that loads the freshly built PicoScan plugin,
# without touching /usr: MeshLab finds plugins relative to its executable (symlinks resolved),
# so the binaries are copied and the system plugins linked.
#   make_prefix.sh PREFIX PLUGIN.so MULTIARCH   (MULTIARCH: e.g. x86_64-linux-gnu)
set -euo pipefail
prefix=$1
plugin=$2
multiarch=$3
system=/usr/lib/$multiarch/meshlab
plugins="$prefix/lib/$multiarch/meshlab/plugins"
mkdir -p "$prefix/bin" "$plugins"
for binary in meshlabserver meshlab; do
  rm -f "$prefix/bin/$binary"
  cp /usr/bin/$binary "$prefix/bin/$binary"
done
ln -sfn "$system/libmeshlab-common.so" "$prefix/lib/$multiarch/meshlab/libmeshlab-common.so"
own=$(basename "$plugin")
for library in "$system"/plugins/*.so; do
  # A system-wide install of this plugin is left out: the fresh build replaces it.
  [ "$(basename "$library")" = "$own" ] && continue
  ln -sfn "$library" "$plugins/"
done
# Remove first: copying onto a symlink would write through it into /usr.
rm -f "$plugins/$own"
cp "$plugin" "$plugins/$own"
