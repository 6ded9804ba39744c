# Sourced by web/screenshot.sh and web/engines.sh: `serve DIR FILE` serves DIR on a free loopback
# port in the background (its pid in $server, the port in $port) and waits until FILE answers
# (at most 5 s). The caller's EXIT trap stops it.
serve() {
  port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
  python3 -m http.server "$port" --bind 127.0.0.1 --directory "$1" >/dev/null 2>&1 &
  server=$!
  for _ in $(seq 50); do
    python3 -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:$port/$2')" \
      2>/dev/null && break
    sleep 0.1
  done
}
