# Sourced by .ci/run and scripts/view.sh: installs what a window needs that the binary does not
# link but loads at start-up (winit opens libX11's helpers and libxkbcommon-x11 with dlopen, so a
# machine without them builds fine and fails only when the window opens). WINDOW_TEST_TOOLS=1
# adds the window test's tools: Xvfb, xdotool and ImageMagick's `import`.
window_packages=""
if command -v dpkg >/dev/null 2>&1; then # Debian and Ubuntu; elsewhere the libraries are the user's
    for package in libx11-xcb1 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0; do
        dpkg -s "$package" >/dev/null 2>&1 || window_packages="$window_packages $package"
    done
fi
if [ "${WINDOW_TEST_TOOLS:-0}" = 1 ]; then
    command -v Xvfb >/dev/null 2>&1 || window_packages="$window_packages xvfb"
    command -v xdotool >/dev/null 2>&1 || window_packages="$window_packages xdotool"
    command -v import >/dev/null 2>&1 || window_packages="$window_packages imagemagick"
fi
if [ -n "$window_packages" ]; then
    echo "== installing what the window needs:$window_packages =="
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
    $SUDO apt-get update -qq
    # shellcheck disable=SC2086 # one word per package
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $window_packages >/dev/null
fi
