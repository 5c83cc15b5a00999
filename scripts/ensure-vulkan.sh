# Sourced by .ci/run and scripts/render.sh: makes sure a Vulkan driver exists, installing
# Debian's software driver (lavapipe) when there is none, and that XDG_RUNTIME_DIR is set.
# VULKAN_ICD_PATTERN narrows the drivers that count (`lvp_icd*` asks for lavapipe itself).
icd_pattern="${VULKAN_ICD_PATTERN:-*.json}"
if ! compgen -G "/usr/share/vulkan/icd.d/$icd_pattern" >/dev/null && ! compgen -G "/etc/vulkan/icd.d/$icd_pattern" >/dev/null; then
    echo "== no Vulkan driver: installing the software one (mesa-vulkan-drivers) =="
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq \
        mesa-vulkan-drivers libvulkan1 libegl1 libegl-mesa0 libgl1-mesa-dri >/dev/null
fi
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
    XDG_RUNTIME_DIR="$(mktemp -d)"
    chmod 700 "$XDG_RUNTIME_DIR"
    export XDG_RUNTIME_DIR
fi
