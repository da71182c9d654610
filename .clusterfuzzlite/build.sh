#!/bin/bash -eu
# ClusterFuzzLite entry: the build script lives in the repository (fuzz/build.sh).
exec "$SRC/visgate/fuzz/build.sh"
