# Sourced by the setup scripts: installs Debian packages by name, only those missing.

# Sets SUDO to () as root, (sudo) otherwise; fails clearly when neither can install.
need_root() {
  SUDO=()
  if [[ $(id -u) -ne 0 ]]; then
    command -v sudo >/dev/null || { echo "$1: not root and no sudo: run as root" >&2; exit 1; }
    SUDO=(sudo)
  fi
}

# apt_install_missing WHO PACKAGE...: refreshes the package lists and installs what is missing.
apt_install_missing() {
  local who=$1 p try
  shift
  local missing=()
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if ((${#missing[@]} == 0)); then
    echo "$who: all $# packages already installed"
    return 0
  fi
  need_root "$who"
  echo "$who: installing ${#missing[@]} package(s): ${missing[*]}"
  # Always refresh: a newly added architecture has no lists yet. A mirror mid-sync fails an
  # index now and then ("File has unexpected size"): retry, then install from the lists
  # that did download (a package missing from them fails below).
  for try in 1 2 3; do
    "${SUDO[@]}" apt-get update -q && break
    ((try < 3)) || { echo "$who: apt-get update failed 3 times; installing from the lists it has" >&2; break; }
    echo "$who: apt-get update failed; retrying in 15 s" >&2
    sleep 15
  done
  DEBIAN_FRONTEND=noninteractive "${SUDO[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
  echo "$who: done"
}
