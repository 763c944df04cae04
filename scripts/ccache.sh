# Sourced by scripts/build and scripts/fuzz: sets `launcher` to the cmake arguments that compile through ccache, or to
# nothing when ccache is not installed or LOOPD_CCACHE=0. The cache lives outside the clone (~/.cache/ccache), and
# paths are hashed relative to $1 (the clone), so a fresh clone on a machine that built loopd before compiles only
# what changed.
launcher=()
if [ "${LOOPD_CCACHE:-1}" != 0 ] && command -v ccache >/dev/null; then
  export CCACHE_BASEDIR="$1" CCACHE_NOHASHDIR=1
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
