# Sourced by setup-deps.sh --vm: fetches the kernel the VM bench boots (scripts/vm-bench.sh)
# without installing it on this machine. It is the kernel Debian's linux-image-amd64
# depends on; its image and the modules the bench loads are unpacked into
# build/vm-kernel/ (about 15 MB), once per kernel version.

# The module folders the guest needs (scripts/vm-bench.sh loads them in order).
vm_kernel_paths=(kernel/drivers/virtio kernel/net/9p kernel/fs/9p kernel/fs/netfs kernel/fs/fscache
                 kernel/net/can kernel/drivers/net/can/dev kernel/drivers/net/can/vcan.ko)

# fetch_vm_kernel DIR: unpacks boot/vmlinuz-VERSION and lib/modules/VERSION/... into DIR.
fetch_vm_kernel() {
  local dir=$1 pkg version deb
  pkg=$(apt-cache depends linux-image-amd64 2>/dev/null | sed -n 's/^ *Depends: \(linux-image-[0-9][^ ]*-amd64\)$/\1/p' | head -1)
  [[ -n $pkg ]] || { echo "setup-deps: apt knows no linux-image-amd64 (run apt-get update?)" >&2; return 1; }
  version=${pkg#linux-image-}
  if [[ -f $dir/boot/vmlinuz-$version && -d $dir/lib/modules/$version ]]; then
    echo "setup-deps: VM kernel $version already in $dir"
    return 0
  fi
  echo "setup-deps: fetching $pkg for the VM bench into $dir (not installed on this machine)"
  rm -rf "$dir"
  mkdir -p "$dir/deb"
  (cd "$dir/deb" && apt-get download -q "$pkg" 2>&1 | grep -v "unsandboxed as root") || true
  deb=$(ls "$dir"/deb/"$pkg"_*.deb 2>/dev/null | head -1)
  [[ -n $deb ]] || { echo "setup-deps: apt-get download $pkg failed" >&2; return 1; }
  local members=("./boot/vmlinuz-$version")
  for p in "${vm_kernel_paths[@]}"; do members+=("./lib/modules/$version/$p"); done
  dpkg-deb --fsys-tarfile "$deb" | tar -x -C "$dir" "${members[@]}"
  rm -rf "$dir/deb"
  echo "setup-deps: VM kernel $version unpacked ($(du -sh "$dir" | cut -f1))"
}
