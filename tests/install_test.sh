#!/usr/bin/env bash
# shrm installed (docs/install.md):
#   1. `cmake --install` into a temporary prefix: the programs, libraries, headers, CMake package,
#      pkg-config files, proto file, units, man pages and completion are there, and nothing
#      installed names the build or the source tree (no RPATH either);
#   2. every program's --version starts with "NAME VERSION" of the CMake project, and names the
#      git revision and the conventions version of docs/conventions.md; bash completion of
#      subcommands, options and option values; the man pages hold the options of --help;
#   3. examples/client, built against the installed package with find_package(shrm): its
#      prefilter_remote (shrm::client) runs a job on an shrmd started here from the prefix and
#      writes the same bytes as `shrm prefilter`; its prefilter_core (shrm::core) computes the same
#      coefficients in process; the daemon's start log line and /metrics carry the version; the
#      SHRM file and the report carry it; pkg-config's shrm-client links the same program;
#   4. the Debian packages (cpack -G DEB): together they hold exactly what `cmake --install
#      --prefix /usr` installs, each the files it should; dependencies: every library the
#      programs link comes from a package their Depends names; installed into an empty root with
#      dpkg --root (maintainer scripts chrootless: the user shrmd, the unit enabled there and not
#      on this host), the packaged `shrm --version` runs, purge removes everything; lintian
#      reports no errors or warnings.
#
# Usage: install_test.sh BUILD_DIR REPO_ROOT VERSION CMAKE CPACK   (CTest: install_test)
set -u

if [ $# -ne 5 ]; then
  echo "usage: $0 BUILD_DIR REPO_ROOT VERSION CMAKE CPACK" >&2
  exit 2
fi
BUILD=$(realpath "$1")
ROOT=$(realpath "$2")
VERSION=$3
CMAKE=$4
CPACK=$5
CONVENTIONS=$(sed -n 's/^Conventions version: \([0-9]*\)$/\1/p' "$ROOT/docs/conventions.md")
MAP=courtyard.exr
BRDF="microfacet:sigma=0.3"
EPSILON=0.05
THREADS=2

TMP=$(mktemp -d "${TMPDIR:-/tmp}/shrm_install_test.XXXXXX")
SHRMD_PID=""
cleanup() {
  [ -n "$SHRMD_PID" ] && kill "$SHRMD_PID" 2>/dev/null && wait "$SHRMD_PID" 2>/dev/null
  rm -rf "$TMP"
}
trap cleanup EXIT
cd "$TMP" || exit 2

FAILURES=0
fail() {
  echo "FAIL: $*"
  FAILURES=$((FAILURES + 1))
}
pass() { echo "ok: $*"; }
skip() { echo "skip: $*"; }
T0=$SECONDS
stage() { echo "== [$((SECONDS - T0)) s] $*"; }

# --- 1. cmake --install ---------------------------------------------------------------------
stage "cmake --install --prefix $TMP/prefix"
P=$TMP/prefix
if ! "$CMAKE" --install "$BUILD" --prefix "$P" >install.log 2>&1; then
  cat install.log
  echo "FAIL: cmake --install"
  exit 1
fi
LIBDIR=$(cd "$P" && ls -d lib/*/cmake/shrm 2>/dev/null | sed 's|/cmake/shrm$||')
[ -n "$LIBDIR" ] || LIBDIR=lib
for f in bin/shrm sbin/shrmd bin/shrm-view "$LIBDIR/shrm/libshrm_imageio.so" "$LIBDIR/shrm/shrm-remote" \
  "$LIBDIR/libshrm_client.a" "$LIBDIR/libshrm_jobs.a" "$LIBDIR/libshrm_shrm.a" \
  "$LIBDIR/cmake/shrm/shrmConfig.cmake" "$LIBDIR/cmake/shrm/shrmConfigVersion.cmake" \
  "$LIBDIR/cmake/shrm/shrmTargets.cmake" "$LIBDIR/pkgconfig/shrm-core.pc" \
  "$LIBDIR/pkgconfig/shrm-jobs.pc" "$LIBDIR/pkgconfig/shrm-client.pc" \
  include/shrm/client/shrm_client.h include/shrm/client/remote_jobs.h \
  include/shrm/jobs/prefilter_job.h include/shrm/core/shrm/prefilter.h \
  include/shrm/core/base/status_macros.h include/shrm/proto/job_codec.h \
  include/shrm/shrm/v1/shrm.pb.h include/shrm/shrm/v1/shrm.grpc.pb.h \
  include/shrm/shrm/v1/shrm.proto include/shrm/shrm/version.h \
  lib/systemd/system/shrmd.service lib/systemd/system/shrmd@.service \
  lib/sysusers.d/shrmd.conf etc/shrmd/shrmd.conf \
  share/man/man1/shrm.1.gz share/man/man1/shrm-prefilter.1.gz share/man/man1/shrm-view.1.gz \
  share/man/man8/shrmd.8.gz share/bash-completion/completions/shrm \
  share/bash-completion/completions/shrmd share/bash-completion/completions/shrm-view \
  share/shrm/envmaps/$MAP share/shrm/ocio/config.ocio share/doc/shrm/README.md \
  share/shrm/shaders/glsl/shrm_common.glsl share/shrm/shaders/wgsl/shrm.wgsl \
  share/doc/shrm/docs/install.md share/doc/shrm/LICENSE; do
  [ -e "$P/$f" ] || fail "install: $f missing"
done
[ -z "$(find "$P" -name '*_test*' -o -name '*_bench*' | head -1)" ] ||
  fail "install: tests, benchmarks or CLI internals installed: $(find "$P" -name '*_test*' -o -name '*_bench*' | head -3)"
[ ! -e "$P/include/shrm/server" ] && [ ! -e "$P/include/shrm/cli" ] ||
  fail "install: server/ or cli/ headers installed (not a public API)"
pass "install: $(find "$P" -type f | wc -l) files under the prefix"
# Nothing installed names the build or the source tree (text files and programs; the images are
# the repository's files as they are, and a PNG's metadata may name where it was made).
refs=$(grep -rlF --exclude='*.png' --exclude='*.exr' -e "$BUILD" -e "$ROOT" "$P" 2>/dev/null)
[ -z "$refs" ] && pass "install: no file names $BUILD or $ROOT" ||
  fail "install: files naming the build or source tree: $refs"
for exe in bin/shrm sbin/shrmd bin/shrm-view; do
  if readelf -d "$P/$exe" | grep -qE 'RPATH|RUNPATH'; then
    fail "install: $exe has an RPATH: $(readelf -d "$P/$exe" | grep -E 'RPATH|RUNPATH')"
  fi
done
grep -q "^ExecStart=$P/sbin/shrmd --config $P/etc/shrmd/shrmd.conf\$" \
  "$P/lib/systemd/system/shrmd.service" &&
  pass "install: shrmd.service runs this prefix's shrmd with its shrmd.conf" ||
  fail "install: shrmd.service ExecStart: $(grep ^ExecStart "$P/lib/systemd/system/shrmd.service")"

# --- 2. --version, completion, man pages ---------------------------------------------------
stage "--version, completion, man pages"
for exe in bin/shrm sbin/shrmd bin/shrm-view; do
  name=$(basename "$exe")
  if out=$("$P/$exe" --version 2>&1); then
    first=$(head -n 1 <<<"$out")
    if [ "$first" = "$name $VERSION" ] && grep -q "^git revision [0-9A-Za-z._+-]*$" <<<"$out" &&
      grep -q "^conventions version $CONVENTIONS$" <<<"$out"; then
      pass "$name --version: $(tr '\n' ' ' <<<"$out")"
    else
      fail "$name --version: '$out' (want '$name $VERSION', a git revision, conventions $CONVENTIONS)"
    fi
  else
    fail "$name --version exited $?: $out"
  fi
done
# The installed shrm loads its image module from the prefix: a PNG map goes through OpenImageIO
# (sRGB-encoded 8-bit input, converted to linear by OpenColorIO).
python3 - "$TMP/map.png" <<'PY'
import struct, sys, zlib
w, h = 16, 8
rows = b"".join(b"\0" + bytes(v for x in range(w) for v in (x * 15, y * 30, 128))
               for y in range(h))
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
       chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
open(sys.argv[1], "wb").write(png)
PY
if out=$("$P/bin/shrm" analyze --env "$TMP/map.png" --epsilon 0.1 2>&1); then
  pass "installed shrm reads a PNG map (module $LIBDIR/shrm/libshrm_imageio.so)"
else
  fail "installed shrm cannot read a PNG map: $out"
fi
# --server runs the installed shrm-remote (the client's own check of the TLS flags answers,
# before any connection is tried).
touch "$TMP/cert.pem"
out=$("$P/bin/shrm" analyze --brdf phong:s=8 --server 127.0.0.1:1 --tls-cert "$TMP/cert.pem" 2>&1)
if grep -q -- '--tls-cert and --tls-key go together' <<<"$out"; then
  pass "installed shrm runs --server through $LIBDIR/shrm/shrm-remote"
else
  fail "installed shrm --server: $out"
fi

# Completion: one shell (with bash-completion when installed) answers every query: a line of
# candidates, sorted, per query.
mapfile -t got < <(bash -c '
  [ -r /usr/share/bash-completion/bash_completion ] && . /usr/share/bash-completion/bash_completion
  . "$1/share/bash-completion/completions/shrm"
  q() {
    COMP_WORDS=("$@"); COMP_CWORD=$((${#COMP_WORDS[@]} - 1))
    COMP_LINE="${COMP_WORDS[*]}"; COMP_POINT=${#COMP_LINE}; COMPREPLY=()
    _shrm_complete 2>/dev/null
    printf "%s\n" "${COMPREPLY[@]}" | sort | tr "\n" " "; echo
  }
  q "$1/bin/shrm" pre
  q "$1/bin/shrm" prefilter --ki
  q "$1/bin/shrm" prefilter --kind ""
  q "$1/sbin/shrmd" --vers
  q "$1/bin/shrm" analyze --env "$1/share/shrm/envmaps/cou"' _ "$P")
want=("prefilter " "--kind " "global local " "--version " "$P/share/shrm/envmaps/$MAP ")
queries=("shrm pre" "shrm prefilter --ki" "shrm prefilter --kind ''" "shrmd --vers"
  "shrm analyze --env .../envmaps/cou")
for i in "${!want[@]}"; do
  [ "${got[$i]:-}" = "${want[$i]}" ] && pass "completion: ${queries[$i]} -> ${got[$i]}" ||
    fail "completion: ${queries[$i]} -> '${got[$i]:-}', want '${want[$i]}'"
done
for page in man1/shrm.1.gz man1/shrm-prefilter.1.gz man1/shrm-view.1.gz man8/shrmd.8.gz; do
  if ! warnings=$(zcat "$P/share/man/$page" | groff -man -Tutf8 -ww -z 2>&1) || [ -n "$warnings" ]; then
    fail "man: $page: groff: $warnings"
  fi
done
if zcat "$P/share/man/man1/shrm-prefilter.1.gz" | grep -q '^\\fB\\-\\-kind\\fR' &&
  zcat "$P/share/man/man8/shrmd.8.gz" | grep -q '^\\fB\\-\\-max\\-jobs\\fR' &&
  zcat "$P/share/man/man1/shrm.1.gz" | grep -q 'shrm\\-prefilter'; then
  pass "man: shrm-prefilter(1), shrmd(8) document their options; shrm(1) refers to the subcommands' pages"
else
  fail "man: options of --help missing from the pages"
fi

# --- 3. examples/client against the installed package -----------------------------------------
stage "examples/client: find_package(shrm) from the prefix"
EX=$TMP/example
if "$CMAKE" -S "$ROOT/examples/client" -B "$EX" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$P" >example-configure.log 2>&1 &&
  "$CMAKE" --build "$EX" -j 2 >example-build.log 2>&1; then
  pass "examples/client: configured and built ($(grep -o 'shrm [0-9.]* (conventions version [0-9]*)' example-configure.log))"
else
  cat example-configure.log example-build.log | tail -n 40
  fail "examples/client: configure or build failed"
fi

# The version rule (docs/install.md, "Versions"): while 0.x, the same MINOR and at least the
# requested PATCH (the acceptance is the example's find_package(shrm 0.1) above).
IFS=. read -r major minor patch <<<"$VERSION"
for request in "$major.$((minor + 1))" "$((major + 1)).0" "$major.$minor.$((patch + 1))"; do
  mkdir -p "version-$request"
  printf 'cmake_minimum_required(VERSION 3.25)\nproject(v LANGUAGES NONE)\nfind_package(shrm %s CONFIG REQUIRED)\n' \
    "$request" >"version-$request/CMakeLists.txt"
  if "$CMAKE" -S "version-$request" -B "version-$request/build" \
    -Dshrm_DIR="$P/$LIBDIR/cmake/shrm" >"version-$request.log" 2>&1; then
    fail "find_package(shrm $request) accepted $VERSION"
  elif grep -q "shrmConfig.cmake, version: $VERSION" "version-$request.log"; then
    pass "find_package(shrm $request) refuses $VERSION (found, incompatible)"
  else
    fail "find_package(shrm $request): $(tail -n 5 "version-$request.log")"
  fi
done

stage "shrmd from the prefix, the CLI, the example's two paths"
MAPFILE=$P/share/shrm/envmaps/$MAP
"$P/sbin/shrmd" --listen 127.0.0.1:0 --spool-dir "$TMP/spool" --metrics-port 0 --max-jobs 1 \
  --job-threads "$THREADS" 2>shrmd.log &
SHRMD_PID=$!
PORT="" METRICS_PORT=""
# Waits for the listening line, or for shrmd to exit; the 5-minute cap only stops a hung start
# (not a timing assumption: a loaded machine starts it in seconds).
for _ in $(seq 3000); do
  PORT=$(sed -n 's/.*"event":"listening".*"port":"\([0-9]*\)".*/\1/p' shrmd.log | head -n 1)
  [ -n "$PORT" ] && break
  kill -0 "$SHRMD_PID" 2>/dev/null || break
  sleep 0.1
done
METRICS_PORT=$(sed -n 's/.*"event":"metrics".*"port":"\([0-9]*\)".*/\1/p' shrmd.log | head -n 1)
if [ -z "$PORT" ]; then
  fail "shrmd: no listening line: $(cat shrmd.log)"
else
  grep '"event":"listening"' shrmd.log | grep -q "\"version\":\"$VERSION\"" &&
    pass "shrmd: listening on 127.0.0.1:$PORT, the log line names version $VERSION" ||
    fail "shrmd: listening line without the version: $(grep listening shrmd.log)"
fi
if [ -n "$METRICS_PORT" ] && exec 3<>"/dev/tcp/127.0.0.1/$METRICS_PORT"; then
  printf 'GET /metrics HTTP/1.0\r\n\r\n' >&3
  metrics=$(cat <&3)
  exec 3<&-
  grep -q "^shrm_build_info{version=\"$VERSION\",revision=\"[^\"]*\",conventions=\"$CONVENTIONS\"} 1" <<<"$metrics" &&
    pass "shrmd: /metrics has shrm_build_info for $VERSION" ||
    fail "shrmd: /metrics without shrm_build_info: $(grep build_info <<<"$metrics")"
else
  fail "shrmd: no metrics endpoint"
fi

"$P/bin/shrm" prefilter --env "$MAPFILE" --brdf "$BRDF" --epsilon "$EPSILON" --threads "$THREADS" \
  -o cli.shrm.exr --report cli.json >cli.log 2>&1 || fail "shrm prefilter: $(cat cli.log)"
grep -q "\"shrm_version\": \"$VERSION\"" cli.json && pass "report: shrm_version $VERSION" ||
  fail "report: no shrm_version $VERSION"
"$P/bin/shrm" info cli.shrm.exr >info.txt 2>&1
grep -qE "shrm:version +$VERSION$" info.txt && pass "SHRM file: shrm:version $VERSION" ||
  fail "SHRM file: no shrm:version $VERSION: $(grep version info.txt)"
if [ -x "$EX/prefilter_remote" ] && [ -n "$PORT" ]; then
  if "$EX/prefilter_remote" "127.0.0.1:$PORT" "$MAPFILE" "$BRDF" "$EPSILON" remote.shrm.exr \
    >remote.log 2>&1 && cmp -s cli.shrm.exr remote.shrm.exr; then
    pass "shrm::client: $(cat remote.log); byte-identical to shrm prefilter"
  else
    fail "shrm::client: $(cat remote.log); $(cmp cli.shrm.exr remote.shrm.exr 2>&1)"
  fi
fi
if [ -x "$EX/prefilter_core" ]; then
  "$EX/prefilter_core" "$MAPFILE" "$BRDF" "$EPSILON" "$THREADS" cli.shrm.exr >core.log 2>&1 &&
    pass "shrm::core: $(cat core.log)" || fail "shrm::core: $(cat core.log)"
fi

# pkg-config: the client example's object linked with the flags of shrm-client alone.
export PKG_CONFIG_PATH=$P/$LIBDIR/pkgconfig
obj=$(find "$EX" -name 'prefilter_remote.cc.o' | head -n 1)
if [ "$(pkg-config --modversion shrm-client 2>&1)" != "$VERSION" ]; then
  fail "pkg-config: shrm-client version $(pkg-config --modversion shrm-client 2>&1)"
elif [ -n "$obj" ] && [ -n "$PORT" ]; then
  # shellcheck disable=SC2046
  if g++ -o pc_remote "$obj" $(pkg-config --libs shrm-client) >pc.log 2>&1 &&
    ./pc_remote "127.0.0.1:$PORT" "$MAPFILE" "$BRDF" "$EPSILON" pc.shrm.exr >>pc.log 2>&1 &&
    cmp -s cli.shrm.exr pc.shrm.exr; then
    pass "pkg-config: linked with \`pkg-config --libs shrm-client\`; the same bytes"
  else
    fail "pkg-config: $(tail -n 5 pc.log)"
  fi
  printf '#include "client/remote_jobs.h"\n#include "shrm/version.h"\nint main() { return shrm::kVersionMajor; }\n' >pc.cc
  # shellcheck disable=SC2046
  g++ -std=c++20 -fsyntax-only $(pkg-config --cflags shrm-client) pc.cc >pc-cflags.log 2>&1 &&
    pass "pkg-config: the public headers compile with \`pkg-config --cflags shrm-client\`" ||
    fail "pkg-config --cflags: $(head -n 5 pc-cflags.log)"
fi
kill "$SHRMD_PID" 2>/dev/null
wait "$SHRMD_PID" 2>/dev/null
SHRMD_PID=""

# --- 4. Debian packages ---------------------------------------------------------------------
if ! command -v dpkg-deb >/dev/null || ! command -v dpkg-shlibdeps >/dev/null; then
  skip "Debian packages: dpkg-deb / dpkg-shlibdeps (dpkg-dev) not installed"
  echo "== [$((SECONDS - T0)) s] $FAILURES failure(s)"
  [ "$FAILURES" -eq 0 ]
  exit
fi
stage "cpack -G DEB"
DEBS=$TMP/debs
if ! "$CPACK" -G DEB --config "$BUILD/CPackConfig.cmake" -B "$DEBS" >cpack.log 2>&1; then
  tail -n 30 cpack.log
  fail "cpack failed"
  exit 1
fi
ARCH=$(dpkg --print-architecture)
declare -A DEB
for pkg in shrm shrmd shrm-view libshrm-dev shrm-imageio; do
  DEB[$pkg]=$DEBS/${pkg}_${VERSION}-1_$ARCH.deb
  [ -f "${DEB[$pkg]}" ] || fail "cpack: ${pkg}_${VERSION}-1_$ARCH.deb missing ($(ls "$DEBS"))"
done
for pkg in "${!DEB[@]}"; do [ -f "${DEB[$pkg]}" ] || exit 1; done
pass "cpack: $(cd "$DEBS" && ls ./*.deb | tr '\n' ' ')"

# Together the packages hold exactly the files of an install with the prefix /usr (less the
# license files, which are in every package's copyright file).
DESTDIR=$TMP/usr-install "$CMAKE" --install "$BUILD" --prefix /usr >/dev/null 2>&1
(cd "$TMP/usr-install" && find . \( -type f -o -type l \) | sed 's|^\.||' |
  grep -vE '^/usr/share/(doc/shrm/LICENSE|shrm/envmaps/LICENSE.txt)$' | sort) >want.txt
for pkg in "${!DEB[@]}"; do
  dpkg-deb -c "${DEB[$pkg]}" | awk '$1 !~ /^d/ {print $6}' | sed 's|^\./|/|' >"files-$pkg.txt"
done
cat files-*.txt |
  grep -vE '^/usr/share/(doc/[^/]*/(copyright|changelog\.Debian\.gz)|lintian/overrides/[^/]*)$' |
  sort >got.txt
if diff want.txt got.txt >files.diff; then
  pass "packages: the $(wc -l <want.txt) files of \`cmake --install --prefix /usr\`, each in one package"
else
  fail "packages differ from the /usr install (< install only, > package only): $(head -n 20 files.diff)"
fi
[ "$(sort got.txt | uniq -d | wc -l)" -eq 0 ] || fail "packages: files in two packages"
has() {  # has PACKAGE FILE...
  local pkg=$1
  shift
  for f in "$@"; do grep -qxF "$f" "files-$pkg.txt" || fail "package $pkg: $f missing"; done
}
has shrm /usr/bin/shrm "/usr/$LIBDIR/shrm/shrm-remote" /usr/share/man/man1/shrm.1.gz /usr/share/man/man1/shrm-batch.1.gz \
  /usr/share/bash-completion/completions/shrm /usr/share/shrm/envmaps/$MAP \
  /usr/share/doc/shrm/copyright /usr/share/doc/shrm/changelog.Debian.gz
has shrmd /usr/sbin/shrmd /usr/share/man/man8/shrmd.8.gz /lib/systemd/system/shrmd.service \
  /lib/systemd/system/shrmd@.service /usr/lib/sysusers.d/shrmd.conf /etc/shrmd/shrmd.conf \
  /usr/share/doc/shrmd/copyright
has shrm-imageio "/usr/$LIBDIR/shrm/libshrm_imageio.so" /usr/share/doc/shrm-imageio/copyright
has shrm-view /usr/bin/shrm-view /usr/share/man/man1/shrm-view.1.gz /usr/share/doc/shrm-view/copyright
has libshrm-dev "/usr/$LIBDIR/libshrm_client.a" "/usr/$LIBDIR/cmake/shrm/shrmConfig.cmake" \
  "/usr/$LIBDIR/pkgconfig/shrm-client.pc" /usr/include/shrm/client/shrm_client.h \
  /usr/include/shrm/shrm/v1/shrm.proto /usr/share/doc/libshrm-dev/copyright
dpkg-deb --ctrl-tarfile "${DEB[shrmd]}" | tar -xO ./conffiles 2>/dev/null | grep -qx /etc/shrmd/shrmd.conf &&
  pass "shrmd: /etc/shrmd/shrmd.conf is a conffile" || fail "shrmd: conffiles"
changelog_version=$(dpkg-deb --fsys-tarfile "${DEB[shrm]}" |
  tar -xO ./usr/share/doc/shrm/changelog.Debian.gz | zcat | sed -n '1s/^shrm (\([^)]*\)).*/\1/p')
[ "$changelog_version" = "$VERSION-1" ] || fail "changelog.Debian.gz: top entry $changelog_version, not $VERSION-1"

# Depends: every shared library a program (or the module) links is provided by a package Depends
# names; the programs depend on the module's package, which they load, at this very version.
for pkg in shrm shrmd shrm-view shrm-imageio; do
  depends=$(dpkg-deb -f "${DEB[$pkg]}" Depends)
  version=$(dpkg-deb -f "${DEB[$pkg]}" Version)
  [ "$version" = "$VERSION-1" ] || fail "$pkg: Version $version"
  [ "$pkg" = shrm-imageio ] || grep -qF "shrm-imageio (= $VERSION-1)" <<<"$depends" ||
    fail "$pkg: Depends lacks shrm-imageio (= $VERSION-1): $depends"
  exe=$(grep -E '^/usr/s?bin/|libshrm_imageio\.so$' "files-$pkg.txt")
  needed=$(readelf -d "$TMP/usr-install$exe" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
  dep_names=$(tr ',|' '\n\n' <<<"$depends" | sed 's/(.*//; s/[[:space:]]//g')
  paths=()
  for so in $needed; do
    paths+=("$(ldconfig -p | awk -v so="$so" '$1 == so {print $NF; exit}')")
  done
  # The packages owning the libraries, in one dpkg -S (dpkg knows /lib or /usr/lib, whichever
  # the package shipped: the other spelling is asked too).
  alternates=()
  for path in "${paths[@]}"; do
    case $path in /usr/*) alternates+=("${path#/usr}") ;; *) alternates+=("/usr$path") ;; esac
  done
  owned=$(dpkg -S "${paths[@]}" "${alternates[@]}" 2>/dev/null)
  owners=()
  for i in "${!paths[@]}"; do
    owner=$(awk -v a="${paths[$i]}" -v b="${alternates[$i]}" '$NF == a || $NF == b {print $1; exit}' <<<"$owned")
    [ -n "$owner" ] || { fail "$pkg: no package owns ${paths[$i]}"; continue; }
    owners+=("${owner%%:*}")
  done
  missing=""
  for owner in $(printf '%s\n' "${owners[@]}" | sort -u); do
    grep -qxF "$owner" <<<"$dep_names" || missing+=" $owner"
  done
  [ -z "$missing" ] && pass "$pkg: Depends names the packages of the ${#owners[@]} libraries $exe links: $depends" ||
    fail "$pkg: Depends lacks the packages of linked libraries:$missing (Depends: $depends)"
done
grep -q adduser <<<"$(dpkg-deb -f "${DEB[shrmd]}" Depends)" || fail "shrmd: Depends without adduser"
synopsis=$(dpkg-deb -f "${DEB[shrmd]}" Description | head -n 1)
[ "$synopsis" = "shrm prefilter service (gRPC)" ] || fail "shrmd: Description synopsis '$synopsis'"
dev_depends=$(dpkg-deb -f "${DEB[libshrm-dev]}" Depends)
for d in libgrpc++-dev libprotobuf-dev libabsl-dev shrm-imageio libopenexr-dev zlib1g-dev \
  libfftw3-dev nlohmann-json3-dev; do
  grep -q "$d" <<<"$dev_depends" || fail "libshrm-dev: Depends lacks $d"
done

stage "dpkg --root: install into an empty root"
if [ "$(id -u)" -eq 0 ]; then
  R=$TMP/root
  mkdir -p "$R/var/lib/dpkg/info" "$R/var/lib/dpkg/updates" "$R/var/lib/dpkg/triggers" "$R/etc"
  : >"$R/var/lib/dpkg/status"
  : >"$R/var/lib/dpkg/available"
  host_link=/etc/systemd/system/multi-user.target.wants/shrmd.service
  host_had_link=0
  [ -e "$host_link" ] && host_had_link=1
  if dpkg --root="$R" --force-script-chrootless --force-depends --log="$TMP/dpkg.log" \
    -i "${DEB[@]}" >dpkg-install.log 2>&1; then
    status=$(dpkg --root="$R" -l shrm shrmd shrm-view libshrm-dev shrm-imageio 2>/dev/null | grep -c '^ii')
    [ "$status" -eq 5 ] && pass "dpkg --root: the 5 packages installed and configured" ||
      fail "dpkg --root: $status of 5 packages configured: $(dpkg --root="$R" -l | tail -n 5)"
  else
    fail "dpkg --root -i: $(tail -n 10 dpkg-install.log)"
  fi
  if out=$("$R/usr/bin/shrm" --version 2>&1) && [ "$(head -n 1 <<<"$out")" = "shrm $VERSION" ]; then
    pass "packaged /usr/bin/shrm --version: $(head -n 1 <<<"$out")"
  else
    fail "packaged shrm --version: $out"
  fi
  for exe in usr/sbin/shrmd usr/bin/shrm-view; do
    [ "$("$R/$exe" --version 2>&1 | head -n 1)" = "$(basename "$exe") $VERSION" ] ||
      fail "packaged $exe --version: $("$R/$exe" --version 2>&1 | head -n 1)"
  done
  grep -qx 'ExecStart=/usr/sbin/shrmd --config /etc/shrmd/shrmd.conf' \
    "$R/lib/systemd/system/shrmd.service" &&
    pass "packaged shrmd.service: ExecStart=/usr/sbin/shrmd --config /etc/shrmd/shrmd.conf" ||
    fail "packaged shrmd.service: $(grep ExecStart "$R/lib/systemd/system/shrmd.service")"
  if ! command -v systemd-sysusers >/dev/null; then
    skip "postinst: no systemd-sysusers here to create the user shrmd in another root"
  elif grep -q '^shrmd:x:[0-9]*:[0-9]*:.*:/usr/sbin/nologin$' "$R/etc/passwd" 2>/dev/null; then
    pass "postinst: the system user shrmd exists in the root"
  else
    fail "postinst: no user shrmd in the root's /etc/passwd"
  fi
  [ "$(readlink "$R$host_link")" = /lib/systemd/system/shrmd.service ] &&
    pass "postinst: shrmd.service enabled in the root" ||
    fail "postinst: shrmd.service not enabled in the root: $(ls -l "$R/etc/systemd/system" 2>&1)"
  [ "$host_had_link" -eq 1 ] || [ ! -e "$host_link" ] || fail "postinst: enabled shrmd on this host"
  if dpkg --root="$R" --force-script-chrootless --force-depends --log="$TMP/dpkg.log" \
    --purge shrm shrmd shrm-view libshrm-dev shrm-imageio >dpkg-purge.log 2>&1; then
    left=$(cd "$R" && find . -type f ! -path './var/lib/dpkg/*' ! -path './etc/*' ! -path './var/lib/systemd/*' | head -n 5)
    [ -z "$left" ] && [ ! -e "$R/etc/shrmd/shrmd.conf" ] && [ ! -e "$R$host_link" ] &&
      pass "dpkg --purge: files, conffile and unit link removed" ||
      fail "dpkg --purge left: $left $(ls "$R/etc/shrmd" "$R$host_link" 2>/dev/null)"
  else
    fail "dpkg --purge: $(tail -n 10 dpkg-purge.log)"
  fi
else
  skip "dpkg --root needs root: extracting the packages instead"
  for pkg in "${!DEB[@]}"; do dpkg-deb -x "${DEB[$pkg]}" "$TMP/root"; done
  [ "$("$TMP/root/usr/bin/shrm" --version | head -n 1)" = "shrm $VERSION" ] &&
    pass "packaged /usr/bin/shrm --version" || fail "packaged shrm --version"
fi

if command -v lintian >/dev/null; then
  stage "lintian"
  lintian --fail-on error,warning --display-level ">=warning" "${DEB[@]}" >lintian.log 2>&1
  rc=$?
  if [ $rc -eq 0 ] && ! grep -qE '^[EW]: ' lintian.log; then
    pass "lintian: no errors or warnings for the 5 packages"
  else
    fail "lintian (exit $rc): $(grep -v 'running with root privileges' lintian.log)"
  fi
else
  skip "lintian not installed"
fi

echo "== [$((SECONDS - T0)) s] $FAILURES failure(s)"
[ "$FAILURES" -eq 0 ]
