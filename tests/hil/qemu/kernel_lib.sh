# shellcheck shell=bash
# The installed Debian kernel (linux-image-amd64) for the QEMU guests, sourced
# (not run) by tests/hil/qemu/run_qemu.sh and make_initramfs.sh (the HIL
# guest) and tests/systemd/ (the systemd guest): which kernel to boot, and
# its modules with their dependencies for an initramfs.

# Prints the version of the newest readable /boot/vmlinuz-* whose modules
# include every RELATIVE_PATH given (e.g. kernel/drivers/net/can/vcan.ko,
# matched with any compression suffix); nothing (status 1) if none has them.
find_kernel_version() {
  local image version found="" module ok
  for image in $(ls -v /boot/vmlinuz-* 2>/dev/null); do
    version=${image#/boot/vmlinuz-}
    [ -r "$image" ] || continue
    ok=1
    for module in "$@"; do
      ls "/lib/modules/$version/$module"* > /dev/null 2>&1 || { ok=0; break; }
    done
    [ "$ok" = 1 ] && found=$version
  done
  [ -n "$found" ] || return 1
  echo "$found"
}

# Copies the modules NAME... of kernel VERSION and what they depend on
# (modinfo's depends:) into DIRECTORY as NAME.ko, decompressed, and writes
# DIRECTORY/order, the load order (dependencies first). Modules built into the
# kernel (modinfo names no file) are skipped. Status 1 with one line on
# stderr when a module is missing.
#   copy_kernel_modules VERSION DIRECTORY NAME...
copy_kernel_modules() {
  local version=$1 directory=$2
  shift 2
  local -A seen=()
  local -a order=()
  _copy_kernel_module() {
    local name=$1 file dependency
    [ -n "${seen[$name]:-}" ] && return 0
    seen[$name]=1
    file=$(modinfo -k "$version" -n "$name" 2>/dev/null) || {
      echo "no module $name for kernel $version" >&2
      return 1
    }
    case $file in (builtin|"(builtin)"|"") return 0 ;; esac
    for dependency in $(modinfo -k "$version" -F depends "$name" | tr ',' ' '); do
      _copy_kernel_module "$dependency" || return 1
    done
    case $file in
      *.ko) cp "$file" "$directory/$name.ko" ;;
      *.ko.xz) xz -dc "$file" > "$directory/$name.ko" ;;
      *.ko.zst) zstd -qdc "$file" > "$directory/$name.ko" ;;
      *.ko.gz) gzip -dc "$file" > "$directory/$name.ko" ;;
      *) echo "module $name: unknown file $file" >&2; return 1 ;;
    esac
    order+=("$name")
  }
  mkdir -p "$directory"
  local name
  for name in "$@"; do _copy_kernel_module "$name" || return 1; done
  printf '%s\n' "${order[@]}" > "$directory/order"
}
