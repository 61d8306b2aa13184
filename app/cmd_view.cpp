// `weft view DIR`: serves a run's output folder and the viewer's page on localhost
// (docs/viewer.md). The folder is read once at start (weft/run_folder.hpp) into one binary the
// page fetches whole; the page itself (viewer/, bundled at build time) is read from the
// viewer's folder.
#include <httplib.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>

#include "command.hpp"
#include "weft/input_file.hpp"
#include "weft/run_folder.hpp"
#include "weft/error.hpp"

namespace fs = std::filesystem;

namespace {

struct ViewArgs {
  std::string dir;
  int port = 8642;
  bool open = false, no_open = false;
};

// The manifest (JSON) and data (one binary) the page loads: per mesh its indices (uint32),
// texture coordinates, positions and added viscosity (float32, little-endian), at byte
// offsets the manifest gives, each a multiple of 4.
struct Payload {
  std::string manifest, data;
};

Payload make_payload(const weft::RunRecording& rec, const std::string& dir, const std::vector<std::string>& run_files) {
  Payload p;
  auto append = [&p](const void* bytes, size_t n) {
    const size_t at = p.data.size();
    p.data.append(static_cast<const char*>(bytes), n);
    return at;
  };
  nlohmann::json meshes = nlohmann::json::array();
  for (const weft::RunMesh& m : rec.meshes) {
    nlohmann::json j = {{"name", m.name},
                        {"vertices", m.vertex_count},
                        {"triangles", m.indices.size() / 3},
                        {"frames", m.frames},
                        {"viscosity_frames", m.viscosity_frames}};
    j["indices_offset"] = append(m.indices.data(), 4 * m.indices.size());
    j["positions_offset"] = append(m.positions.data(), 4 * m.positions.size());
    j["texcoords_offset"] = m.texcoords.empty() ? nlohmann::json(nullptr) : nlohmann::json(append(m.texcoords.data(), 4 * m.texcoords.size()));
    j["viscosity_offset"] = m.viscosity.empty() ? nlohmann::json(nullptr) : nlohmann::json(append(m.viscosity.data(), 4 * m.viscosity.size()));
    meshes.push_back(j);
  }
  nlohmann::json manifest = {{"folder", dir},
                             {"frames", rec.times.size()},
                             {"times", rec.times},
                             {"positions_source", rec.positions_source},
                             {"viscosity_source", rec.viscosity_source},
                             {"uv_scale", rec.uv_scale},
                             {"data_bytes", p.data.size()},
                             {"run_files", run_files},
                             {"meshes", meshes}};
  p.manifest = manifest.dump();
  return p;
}

// The viewer's bundled page: $WEFT_VIEWER_DIR, else share/weft/viewer beside an installed
// weft, else the build folder's viewer/ (where the build puts it).
fs::path find_viewer_dir() {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("WEFT_VIEWER_DIR"); env && *env) candidates.emplace_back(env);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path().parent_path() / "share" / "weft" / "viewer");
  candidates.emplace_back(WEFT_VIEWER_BUILD_DIR);
  for (const fs::path& c : candidates)
    if (fs::is_regular_file(c / "index.html", ec)) return c;
  std::string tried;
  for (const fs::path& c : candidates) tried += (tried.empty() ? "" : ", ") + c.string();
  throw std::runtime_error("the viewer's page is not installed (no index.html in " + tried +
                           "); it is built by the target weft_viewer, which needs node and npm (see docs/viewer.md)");
}

// Sends `bytes` (which outlive the server) as they are. Not res.set_content: cpp-httplib would
// then compress text with brotli or gzip on every request, which takes seconds for the
// bundled page's half megabyte; on the loopback the plain bytes arrive sooner.
void send(httplib::Response& res, const std::string& bytes, const std::string& type) {
  res.set_header("Cache-Control", "no-store");
  res.set_content_provider(bytes.size(), type, [&bytes](size_t offset, size_t length, httplib::DataSink& sink) {
    return sink.write(bytes.data() + offset, std::min<size_t>(length, 1 << 20));
  });
}

bool display_present() {
  for (const char* v : {"DISPLAY", "WAYLAND_DISPLAY"})
    if (const char* s = std::getenv(v); s && *s) return true;
  return false;
}

int run_view(const ViewArgs& a) {
  const auto start = std::chrono::steady_clock::now();
  // Bad input first: the folder, then the port, then the page's files.
  const weft::RunRecording rec = weft::read_run_folder(a.dir);
  std::map<std::string, std::string> run_files;
  std::vector<std::string> run_file_names;
  for (const char* name : {"summary.json", "energy.csv"}) {
    std::error_code ec;
    if (!fs::is_regular_file(fs::path(a.dir) / name, ec)) continue;
    run_files[name] = weft::read_input_file((fs::path(a.dir) / name).string(), name);
    run_file_names.push_back(name);
  }
  const Payload payload = make_payload(rec, fs::absolute(a.dir).lexically_normal().string(), run_file_names);
  const fs::path viewer_dir = find_viewer_dir();
  std::map<std::string, std::pair<std::string, std::string>> assets;  // path -> (content type, bytes)
  static const std::map<std::string, std::string> types = {
      {".html", "text/html; charset=utf-8"}, {".js", "text/javascript; charset=utf-8"}, {".css", "text/css; charset=utf-8"},
      {".svg", "image/svg+xml"}, {".png", "image/png"}};
  for (const auto& e : fs::directory_iterator(viewer_dir)) {
    const auto type = types.find(e.path().extension().string());
    if (e.is_regular_file() && type != types.end())
      assets["/" + e.path().filename().string()] = {type->second, weft::read_input_file(e.path().string(), "viewer file")};
  }

  httplib::Server server;
  // Only SO_REUSEADDR: the library's default, SO_REUSEPORT, would let a second server share a
  // port already in use instead of being refused.
  server.set_socket_options([](int sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  server.Get("/", [&assets](const httplib::Request&, httplib::Response& res) {
    const auto& [type, bytes] = assets.at("/index.html");
    send(res, bytes, type);
  });
  for (const auto& [path, asset] : assets)
    server.Get(path, [&asset = asset](const httplib::Request&, httplib::Response& res) { send(res, asset.second, asset.first); });
  server.Get("/run/manifest.json", [&payload](const httplib::Request&, httplib::Response& res) {
    send(res, payload.manifest, "application/json");
  });
  server.Get("/run/data.bin", [&payload](const httplib::Request&, httplib::Response& res) {
    send(res, payload.data, "application/octet-stream");
  });
  for (const auto& [name, bytes] : run_files)
    server.Get("/run/" + name, [&bytes = bytes, type = name.ends_with(".json") ? "application/json" : "text/csv"](
                                   const httplib::Request&, httplib::Response& res) { send(res, bytes, type); });

  const std::string host = "127.0.0.1";
  int port = a.port;
  errno = 0;
  if (port == 0) {
    port = server.bind_to_any_port(host);
    if (port <= 0) throw weft::InputError("cannot listen on " + host + " on any port: " + std::strerror(errno));
  } else if (!server.bind_to_port(host, port)) {
    const int error = errno;
    throw weft::InputError("cannot listen on " + host + ":" + std::to_string(port) + ": " +
                           (error == EADDRINUSE ? std::string("the port is in use") : std::strerror(error)) +
                           " (choose another with --port, or --port 0 for any free one)");
  }

  // Ctrl-C and SIGTERM stop the server; a thread waits for them (they are blocked in every
  // thread, so the server's threads never take them).
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  std::atomic<bool> done{false};
  std::thread waiter([&] {
    const timespec poll{0, 200'000'000};
    while (!done) {
      if (sigtimedwait(&stop_signals, nullptr, &poll) > 0) {
        server.stop();
        return;
      }
    }
  });

  const std::string url = "http://" + host + ":" + std::to_string(port) + "/";
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::string meshes;
  for (const weft::RunMesh& m : rec.meshes)
    meshes += (meshes.empty() ? "" : ", ") + m.name + " " + std::to_string(m.vertex_count) + " vertices";
  std::printf("weft view: %s: %zu frames (%s; positions from %s), read in %.2f s\n", a.dir.c_str(), rec.times.size(),
              meshes.c_str(), rec.positions_source.c_str(), seconds);
  std::printf("serving %s (Ctrl-C to stop)\n", url.c_str());
  std::fflush(stdout);
  if (a.open || (!a.no_open && display_present())) {
    if (std::system("command -v xdg-open > /dev/null 2>&1") == 0) {
      const std::string command = "xdg-open '" + url + "' > /dev/null 2>&1 &";
      if (std::system(command.c_str()) != 0) std::fprintf(stderr, "weft view: could not start a browser; open %s\n", url.c_str());
    } else if (a.open) {
      std::fprintf(stderr, "weft view: xdg-open is not installed; open %s in a browser\n", url.c_str());
    }
  }
  const bool listened = server.listen_after_bind();
  done = true;
  waiter.join();
  if (!listened) {
    std::fprintf(stderr, "weft view: the server on %s stopped with an error\n", url.c_str());
    return 1;
  }
  std::printf("weft view: stopped\n");
  return weft::app::kExitOk;
}

weft::app::RegisterCommand reg{{"", "view", "Play a run's output folder in a browser (serves it on localhost)",
  [](CLI::App& sub) {
    auto a = std::make_shared<ViewArgs>();
    sub.add_option("dir", a->dir, "Output folder of `weft run`")->required();
    sub.add_option("--port", a->port, "Port on 127.0.0.1 to serve on (default 8642; 0: any free port)")
        ->check(CLI::Range(0, 65535));
    auto* open = sub.add_flag("--open", a->open, "Open the page in a browser (xdg-open) even without a display");
    sub.add_flag("--no-open", a->no_open, "Do not open a browser (by default one opens when a display exists)")->excludes(open);
    sub.footer(
        "Reads DIR once (animation.glb or the frames in DIR/frames, energy.csv, summary.json) and serves a page that\n"
        "plays the run: the cloth and colliders shaded, play, pause, scrub and speed, the cloth coloured by added\n"
        "viscosity (needs --format ply or glb) or by strain (needs texture coordinates: --format obj or glb), the\n"
        "energy curves with a cursor at the current time, and the summary. Prints the URL; serves until Ctrl-C.\n"
        "Exit status: 0 stopped by Ctrl-C or SIGTERM, 2 a missing DIR, a folder that is not a run's, a file that\n"
        "cannot be read, or a port in use; 1 when the viewer's page is not installed.");
    return std::function<int()>([a] { return run_view(*a); });
  }, 25}};

}  // namespace
