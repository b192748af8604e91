#!/usr/bin/env bash
# The VM bench: the production SocketCAN and UART code paths on a real kernel. This
# machine's kernel has no CAN and libserialport cannot open a pty, so Debian's own kernel
# (unpacked into build/vm-kernel by setup-deps.sh --vm, not installed on this machine)
# boots under qemu (TCG: KVM here hangs or aborts on an MSR) with this machine's root shared
# read-only over 9p, loads vcan and the CAN modules, and gives the guest 16550 UARTs:
# ttyS1 and ttyS2 are joined through one qemu socket, a null-modem cable. The guest
# chroots into the shared root and runs a command of the project's (default: the VM
# checks, tests/vm/guest-checks.sh) with /tmp on tmpfs and OUT writable; its exit status
# is this script's.
#
#   scripts/vm-bench.sh [--build DIR] [--out DIR] [--timeout S] [-- COMMAND...]
#     --build DIR    the build whose binaries the checks run (default build/ci)
#     --out DIR      console log, the command's log and exit status (default build/vm)
#   Paths are relative to the project's root; so is the COMMAND's working directory.
#     --timeout S    power the VM off after S seconds (default 900)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=build/ci out=build/vm timeout=900
while (($#)); do
  case "$1" in
    --build|--out|--timeout)
      (($# >= 2)) || { echo "vm-bench: $1 needs a value" >&2; exit 2; }
      case "$1" in --build) build=$2 ;; --out) out=$2 ;; --timeout) timeout=$2 ;; esac
      shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) echo "vm-bench: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
done
cmd=("$@")
if ((${#cmd[@]} == 0)); then
  cmd=(tests/vm/guest-checks.sh "$build")
  for b in tests/executive_hil_test hil/cairn-hil basestation/cairn-base firmware/cairn-robot; do
    [[ -x $build/$b ]] || { echo "vm-bench: $build/$b missing: run scripts/build.sh ${build#build/}" >&2; exit 2; }
  done
fi

kdir=build/vm-kernel
kernel=$(ls "$kdir"/boot/vmlinuz-* 2>/dev/null | sort -V | tail -1 || true)
[[ -n $kernel ]] || { echo "vm-bench: no kernel in $kdir: run scripts/setup-deps.sh --vm" >&2; exit 2; }
version=${kernel##*/vmlinuz-}
modules=$kdir/lib/modules/$version
command -v qemu-system-x86_64 >/dev/null || { echo "vm-bench: qemu-system-x86_64 missing: run scripts/setup-deps.sh --vm" >&2; exit 2; }
# The initramfs has no libraries: Debian's dynamically linked busybox would not start.
[[ -x /bin/busybox ]] && ! ldd /bin/busybox >/dev/null 2>&1 ||
  { echo "vm-bench: no static /bin/busybox: run scripts/setup-deps.sh --vm (busybox-static)" >&2; exit 2; }

mkdir -p "$out"
out=$(cd "$out" && pwd)
rm -f "$out"/{console.log,guest.log,rc,run.sh}
work=$(mktemp -d /tmp/cairn-vm.XXXXXX)
qemu=
trap '[[ -n $qemu ]] && kill "$qemu" 2>/dev/null; rm -rf "$work"' EXIT

# The initramfs: busybox, the modules in load order (no modules.dep needed), and /init.
ko=(kernel/drivers/virtio/virtio_ring kernel/drivers/virtio/virtio kernel/drivers/virtio/virtio_pci_legacy_dev
    kernel/drivers/virtio/virtio_pci_modern_dev kernel/drivers/virtio/virtio_pci kernel/net/9p/9pnet
    kernel/net/9p/9pnet_virtio kernel/fs/netfs/netfs kernel/fs/fscache/fscache kernel/fs/9p/9p
    kernel/net/can/can kernel/net/can/can-raw kernel/drivers/net/can/dev/can-dev kernel/drivers/net/can/vcan)
mkdir -p "$work"/initrd/{bin,lib/modules,proc,sys,dev,host}
cp /bin/busybox "$work/initrd/bin/"
for m in "${ko[@]}"; do
  [[ -f $modules/$m.ko ]] || { echo "vm-bench: $modules/$m.ko missing (kernel $version)" >&2; exit 2; }
  cp "$modules/$m.ko" "$work/initrd/lib/modules/"
done
printf '%s\n' "${ko[@]##*/}" > "$work/initrd/lib/modules/order"
cat > "$work/initrd/init" <<'INIT'
#!/bin/busybox sh
/bin/busybox --install -s /bin
mount -t proc proc /proc; mount -t sysfs sys /sys; mount -t devtmpfs dev /dev
fail() { echo "vm-bench guest: $*"; poweroff -f; }
while read -r m; do insmod "/lib/modules/$m.ko" || fail "insmod $m failed"; done < /lib/modules/order
mount -t 9p -o trans=virtio,version=9p2000.L,ro hostroot /host || fail "cannot mount the host root"
mount -t tmpfs tmp /host/tmp
mkdir -p /host/tmp/out
mount -t 9p -o trans=virtio,version=9p2000.L out /host/tmp/out || fail "cannot mount the output folder"
mount -t proc proc /host/proc; mount -t sysfs sys /host/sys; mount -t devtmpfs dev /host/dev
mkdir -p /host/dev/pts /host/dev/shm
mount -t devpts devpts /host/dev/pts; mount -t tmpfs shm /host/dev/shm
ip link set lo up
ip link add dev vcan0 type vcan && ip link set vcan0 up || fail "cannot create vcan0"
echo "vm-bench guest: kernel $(uname -r), $(nproc) CPUs, vcan0 up; running /tmp/out/run.sh"
chroot /host /bin/sh /tmp/out/run.sh > /host/tmp/out/guest.log 2>&1
echo $? > /host/tmp/out/rc
sync
echo "vm-bench guest: done, exit status $(cat /host/tmp/out/rc)"
poweroff -f
INIT
chmod +x "$work/initrd/init"
(cd "$work/initrd" && find . | cpio -o -H newc --quiet | gzip -1 > "$work/initrd.gz")

{
  echo "cd '$root'"
  echo "export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin HOME=/root TMPDIR=/tmp"
  echo "export CYCLONEDDS_URI='file://$root/config/dds/loopback.xml'"
  printf 'exec'; printf " %q" "${cmd[@]}"; echo
} > "$out/run.sh"

echo "vm-bench: kernel $version, TCG, command: ${cmd[*]}"
start=$(date +%s)
set +e
timeout "$timeout" qemu-system-x86_64 -machine accel=tcg -cpu max -smp 2 -m 2048 -nodefaults -no-reboot \
  -display none -kernel "$kernel" -initrd "$work/initrd.gz" -append "console=ttyS0 quiet panic=-1" \
  -virtfs local,path=/,mount_tag=hostroot,security_model=none,readonly=on,multidevs=remap \
  -virtfs local,path="$out",mount_tag=out,security_model=none,multidevs=remap \
  -serial file:"$out/console.log" \
  -chardev socket,id=uart1,path="$work/uart.sock",server=on,wait=off -serial chardev:uart1 \
  -chardev socket,id=uart2,path="$work/uart.sock" -serial chardev:uart2 &
qemu=$!
# The guest's log as it grows; tail ends once qemu has and it has read the rest.
tail -n +1 -F -s 0.2 --pid="$qemu" "$out/guest.log" 2>/dev/null
wait "$qemu"
qemu_rc=$?
qemu=
set -e
echo "vm-bench: VM off after $(( $(date +%s) - start )) s"
if [[ ! -f $out/rc ]]; then
  echo "vm-bench: the guest wrote no exit status (qemu exit $qemu_rc; timeout $timeout s?); its console:" >&2
  tail -n 30 "$out/console.log" >&2 || true
  exit 1
fi
rc=$(cat "$out/rc")
echo "vm-bench: guest command exit status $rc"
exit "$rc"
