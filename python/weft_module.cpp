// The Python module `weft` (docs/python.md): a scene loaded into a Simulation, stepped from
// Python, its positions and velocities seen as numpy arrays over the simulation's own storage,
// pins and colliders moved between steps, energies and step statistics read, and the outputs
// of `weft run` written. A thin shell over the library, like the command.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "weft/exports.hpp"
#include "weft/recording.hpp"
#include "weft/atomic_file.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"
#include "weft/simulation.hpp"
#include "weft/threads.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace {

using weft::Simulation;

const char* shape_name(weft::ColliderShape s) {
  switch (s) {
    case weft::ColliderShape::kPlane: return "plane";
    case weft::ColliderShape::kSphere: return "sphere";
    case weft::ColliderShape::kCapsule: return "capsule";
    case weft::ColliderShape::kBox: return "box";
    case weft::ColliderShape::kMesh: return "mesh";
    case weft::ColliderShape::kBody: return "body";
  }
  return "?";
}

// A write that failed raises OSError with the command line's wording.
[[noreturn]] void raise_os_error(const std::string& message) {
  PyErr_SetString(PyExc_OSError, message.c_str());
  throw py::error_already_set();
}

void write_file(const std::string& path, const std::function<void(std::ostream&)>& content) {
  try {
    weft::write_file_atomically(path, content);
  } catch (const std::exception& e) {
    raise_os_error("could not write " + path + ": " + e.what());
  }
}

std::string path_text(const py::object& path) { return py::str(py::module_::import("os").attr("fspath")(path)); }

// A scene: a path (str or os.PathLike) to a scene file, or a dict in the scene file's layout.
weft::Scene load(const py::object& scene, const std::optional<std::string>& base_dir) {
  if (py::isinstance<py::dict>(scene)) {
    // numpy arrays and numbers in the dict become JSON lists and numbers.
    const py::object to_list = py::cpp_function([](const py::object& o) -> py::object {
      if (py::hasattr(o, "tolist")) return o.attr("tolist")();
      throw py::type_error("scene dict: a value of type " + std::string(py::str(o.get_type().attr("__name__"))) +
                           " is not JSON (numbers, strings, booleans, lists and dicts are)");
    });
    const std::string text =
        py::str(py::module_::import("json").attr("dumps")(scene, py::arg("default") = to_list, py::arg("indent") = 1));
    return weft::parse_scene_text(text, "scene (dict)", base_dir.value_or("."));
  }
  if (base_dir) throw py::value_error("base_dir applies to a scene given as a dict (a scene file's relative paths are relative to its folder)");
  return weft::load_scene(path_text(scene));
}

// The scene with the keyword arguments' settings in place of its own, checked by the library as
// `weft run` checks its options.
weft::Scene overridden(weft::Scene scene, const weft::SceneOverrides& overrides) {
  weft::apply_overrides(scene, overrides, "Simulation()");
  return scene;
}

/// The Python object `weft.Simulation`: the library's Simulation and the frames recorded for
/// the outputs that cover a whole run (energy.csv, summary.json, glb, pc2).
class PySimulation {
 public:
  PySimulation(const py::object& scene, const std::optional<std::string>& base_dir, const weft::SceneOverrides& overrides)
      : sim_(std::make_unique<Simulation>(overridden(load(scene, base_dir), overrides))), recording_(*sim_, true, true) {}
  /// A new simulation of `model`, at the scene's start.
  explicit PySimulation(std::shared_ptr<const weft::Model> model)
      : sim_(std::make_unique<Simulation>(std::move(model))), recording_(*sim_, true, true) {}

  Simulation& sim() { return *sim_; }
  const Simulation& sim() const { return *sim_; }
  int vertex_count() const { return sim_->vertex_count(); }

  void advance(double t) {
    const double now = sim_->time();
    if (!(t >= now) || !std::isfinite(t))
      throw weft::InputError("advance: the time " + std::to_string(t) + " s is before the current time " +
                             std::to_string(now) + " s");
    const auto start = std::chrono::steady_clock::now();
    {
      // Other Python threads run while this one steps (simulations of one model, new_run, may
      // be stepped in several threads at once). The arrays over this simulation's state must
      // not be written meanwhile.
      py::gil_scoped_release release;
      sim_->advance_to(t);
    }
    wall_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  void step(long n) {
    if (n < 0) throw weft::InputError("step: the number of steps must be >= 0, got " + std::to_string(n));
    for (long k = 0; k < n; ++k) advance(sim_->time() + sim_->scene().integrator.dt);
  }

  /// The frame times of `weft run` on this scene: 0, then every frame interval to the duration.
  std::vector<double> frame_times() const {
    const weft::Scene& sc = sim_->scene();
    const long frames = std::lround(std::floor(sc.duration / sc.frame_interval + 1e-9));
    std::vector<double> times{0.0};
    for (long f = 1; f <= frames; ++f) times.push_back(std::min(sc.duration, f * sc.frame_interval));
    return times;
  }

  // A numpy array of #V by 3 doubles over `v`'s storage, kept alive by `owner`.
  static py::array view(weft::VecX& v, const py::object& owner) {
    return py::array(py::dtype::of<double>(), {v.size() / 3, Eigen::Index(3)},
                     {3 * static_cast<py::ssize_t>(sizeof(double)), static_cast<py::ssize_t>(sizeof(double))}, v.data(),
                     owner);
  }

  py::dict energies() {
    const weft::EnergyRow e = sim_->energies();
    return energy_dict(e);
  }
  static py::dict energy_dict(const weft::EnergyRow& e) {
    py::dict d;
    d["time"] = e.time;
    d["kinetic"] = e.kinetic;
    d["elastic"] = e.elastic;
    d["gravity"] = e.gravity;
    d["viscous_dissipated"] = e.viscous_dissipated;
    d["numerical_dissipated"] = e.numerical_dissipated;
    d["contact_work"] = e.contact_work;
    d["fail_safe_work"] = e.fail_safe_work;
    d["total"] = e.total();
    return d;
  }

  py::dict statistics() const {
    // Every step statistic, named by its field (WEFT_STEP_STATISTICS).
    const weft::StepStatistics& s = sim_->step_statistics();
    py::dict d;
    for (const weft::StepStatistic& st : weft::kStepStatistics) {
      if (st.count) {
        d[st.field] = s.*st.count;
      } else {
        d[st.field] = s.*st.value;
      }
    }
    return d;
  }

  void move_pins(const py::array_t<long, py::array::c_style | py::array::forcecast>& nodes,
                 const py::array_t<double, py::array::c_style | py::array::forcecast>& targets,
                 std::optional<double> over) {
    if (nodes.ndim() != 1) throw weft::InputError("move_pins: the vertices must be a 1-D array of indices");
    if (targets.ndim() != 2 || targets.shape(1) != 3 || targets.shape(0) != nodes.shape(0))
      throw weft::InputError("move_pins: the targets must be an array of " + std::to_string(nodes.shape(0)) +
                             " by 3 (one position per vertex)");
    std::vector<int> n(static_cast<size_t>(nodes.shape(0)));
    std::vector<weft::Vec3> x(n.size());
    for (size_t k = 0; k < n.size(); ++k) {
      const long i = nodes.at(static_cast<py::ssize_t>(k));
      n[k] = i < 0 || i > std::numeric_limits<int>::max() ? -1 : static_cast<int>(i);
      if (n[k] < 0) throw weft::InputError("move_pins: vertex " + std::to_string(i) + " does not exist (the cloth has " +
                                           std::to_string(vertex_count()) + " vertices)");
      for (int d = 0; d < 3; ++d) x[k][d] = targets.at(static_cast<py::ssize_t>(k), d);
    }
    sim_->move_pins(n, x, arrival(over));
  }

  void move_collider(long k, const weft::Vec3& translation, const weft::Vec3& rotation_deg, std::optional<double> over) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = weft::rotation_from_degrees(rotation_deg);
    pose.translation() = translation;
    sim_->move_collider(collider_index(k), pose, arrival(over));
  }

  py::array collider_pose(long k) const {
    const Eigen::Isometry3d T = sim_->collider_pose(collider_index(k), sim_->time());
    py::array_t<double> out({4, 4});
    auto m = out.mutable_unchecked<2>();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m(r, c) = T.matrix()(r, c);
    return out;
  }

  // Outputs of the current state.
  void write_obj(const std::string& path) const {
    const int n = vertex_count();
    const double* x = sim_->positions().data();
    write_file(path, [&](std::ostream& o) {
      const weft::AnimatedMesh& cloth = recording_.cloth();
      weft::write_textured_obj(o, x, n, cloth.texcoords, weft::vertex_normals(x, n, cloth.triangles), cloth.triangles);
    });
  }
  void write_ply(const std::string& path) const {
    const weft::VecX eta = sim_->added_viscosity_per_vertex();
    write_file(path, [&](std::ostream& o) {
      weft::write_ply_frame(o, sim_->positions().data(), vertex_count(), eta.data(), recording_.cloth().triangles);
    });
  }
  void write_collider_obj(long k, const std::string& path) const {
    weft::Points positions;
    weft::Triangles triangles;
    sim_->collider_surface(collider_index(k), sim_->time(), positions, triangles);
    try {
      weft::write_obj(path, positions, triangles);
    } catch (const std::exception& e) {
      raise_os_error("could not write " + path + ": " + e.what());
    }
  }

  // The recorded frames and what is written from them.
  void record_frame() {
    energy_.push_back(sim_->energies());
    recording_.add_frame(*sim_);
  }
  size_t frames_recorded() const { return recording_.frame_count(); }
  py::list recorded_energies() const {
    py::list l;
    for (const weft::EnergyRow& e : energy_) l.append(energy_dict(e));
    return l;
  }
  void require_frames(const char* what) const {
    if (recording_.frame_count() == 0)
      throw weft::InputError(std::string(what) + ": no frames recorded (call record_frame() at the frames to keep)");
  }
  void write_energy_csv(const std::string& path) const {
    write_file(path, [&](std::ostream& o) { o << weft::energy_csv(energy_); });
  }
  void write_glb(const std::string& path) const {
    require_frames("write_glb");
    write_file(path, [&](std::ostream& o) { recording_.write_glb(o); });
  }
  void write_usda(const std::string& path) const {
    require_frames("write_usda");
    write_file(path, [&](std::ostream& o) { recording_.write_usda(o); });
  }
  void write_pc2(const std::string& path, std::optional<std::string> rest_path) const {
    require_frames("write_pc2");
    if (!rest_path) {
      const fs::path p(path);
      rest_path = (p.parent_path() / (p.stem().string() + "_rest.obj")).string();
    }
    write_file(path, [&](std::ostream& o) { recording_.write_pc2(o); });
    write_file(*rest_path, [&](std::ostream& o) { recording_.write_rest_obj(o); });
  }
  /// summary.json's fields for the run so far, its energies those of the recorded frames.
  nlohmann::json summary() const {
    weft::RunResult r;
    r.energy = energy_;
    r.steps = sim_->step_statistics();
    r.damping = sim_->damping_statistics();
    r.wall_seconds = wall_seconds_;
    r.damping_ratio = sim_->scene().effective_damping_ratio();
    r.vertices = vertex_count();
    r.triangles = static_cast<long>(sim_->mesh().triangles.size());
    return weft::summary_json(*sim_, r);
  }
  void write_summary(const std::string& path) const {
    const nlohmann::json j = summary();
    write_file(path, [&](std::ostream& o) { o << j.dump(2) << "\n"; });
  }

 private:
  std::unique_ptr<Simulation> sim_;
  /// The frames recorded for the animations, the cloth's texture coordinates and triangles.
  weft::FrameRecording recording_;
  std::vector<weft::EnergyRow> energy_;
  double wall_seconds_ = 0;

  double arrival(std::optional<double> over) const {
    return sim_->time() + over.value_or(sim_->scene().integrator.dt);
  }
  size_t collider_index(long k) const {
    const long n = static_cast<long>(sim_->collider_count());
    if (k < 0 || k >= n)
      throw weft::InputError("collider " + std::to_string(k) + " does not exist (the scene has " + std::to_string(n) +
                             " colliders)");
    return static_cast<size_t>(k);
  }
};

py::object to_python(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

// weft.sweep(): the sweep driver, weft_sweep (python/weft_sweep, docs/sweeps.md), imported from the
// source tree this module was built from unless it is importable already; its runs use this
// build's `weft` command unless weft= or $WEFT_EXE says otherwise.
py::object sweep(const py::args& args, py::kwargs kwargs) {
  py::module_ driver;
  try {
    driver = py::module_::import("weft_sweep");
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_ModuleNotFoundError)) throw;
#ifdef WEFT_PYTHON_SOURCE_DIR
    py::module_::import("sys").attr("path").attr("append")(WEFT_PYTHON_SOURCE_DIR);
#endif
    driver = py::module_::import("weft_sweep");
  }
#ifdef WEFT_COMMAND
  const char* env = std::getenv("WEFT_EXE");
  if (!kwargs.contains("weft") && !(env && *env) && std::filesystem::exists(WEFT_COMMAND)) kwargs["weft"] = WEFT_COMMAND;
#endif
  return driver.attr("sweep")(*args, **kwargs);
}

}  // namespace

PYBIND11_MODULE(weft, m) {
  m.doc() = "weft, a cloth simulator: load a scene, step it, read its state as numpy arrays (docs/python.md)";
  m.attr("__version__") = WEFT_VERSION;
  // Bad input (a scene, a file, an argument): the command line's message, as a ValueError.
  py::register_exception<weft::InputError>(m, "InputError", PyExc_ValueError);
  m.def("set_thread_count", [](int n) {
          if (n < 0) throw weft::InputError("thread count must be 0 (every core) or positive, got " + std::to_string(n));
          weft::set_thread_count(n);
        },
        py::arg("n"),
        "Threads for the parallel parts of a step: n >= 1, or 0 for every core (the default). Results are the "
        "same bits at every count.");
  m.def("thread_count", &weft::thread_count, "The threads a parallel part of a step may use now");
  m.def("sweep", &sweep,
        "sweep(spec, out, client=None, *, scheduler=None, workers=None, weft=None, base_dir=None, quiet=True, "
        "rerun_other_builds=False): runs a sweep file's runs (a path, or a dict in its layout) on Dask into the folder "
        "`out` and returns results.csv's rows as a pandas DataFrame; client: a dask.distributed.Client (default: a "
        "local cluster of `workers`). Runs already finished in `out` are skipped, those another weft build made too "
        "unless rerun_other_builds (results.csv's weft_version names each run's build). The "
        "driver is weft_sweep (python/weft_sweep, docs/sweeps.md); the runs use the weft command of this build unless "
        "weft= or $WEFT_EXE names another.");

  py::class_<PySimulation>(m, "Simulation",
                           "A scene ready to step: Simulation(path) reads a scene file, Simulation(dict, base_dir=...) "
                           "a dict in the scene file's layout (relative paths in it against base_dir, default the "
                           "current folder). Bad input raises weft.InputError (a ValueError) with the message "
                           "`weft run` prints. The keyword arguments replace the scene's settings as `weft run`'s "
                           "options of the same names do: method, alpha, dt, duration, tolerance, damping_ratio, "
                           "newton, preconditioner.")
      .def(py::init([](const py::object& scene, const py::object& base_dir, const std::optional<std::string>& method,
                       std::optional<double> alpha, std::optional<double> dt, std::optional<double> duration,
                       std::optional<double> tolerance, std::optional<double> damping_ratio,
                       std::optional<double> newton, const std::optional<std::string>& preconditioner) {
             weft::SceneOverrides o;
             o.method = method.value_or("");
             o.alpha = alpha;
             o.dt = dt;
             o.duration = duration;
             o.tolerance = tolerance;
             o.damping_ratio = damping_ratio;
             o.newton = newton;
             o.preconditioner = preconditioner.value_or("");
             return std::make_unique<PySimulation>(
                 scene, base_dir.is_none() ? std::nullopt : std::optional<std::string>(path_text(base_dir)), o);
           }),
           py::arg("scene"), py::arg("base_dir") = py::none(), py::kw_only(), py::arg("method") = py::none(),
           py::arg("alpha") = py::none(), py::arg("dt") = py::none(), py::arg("duration") = py::none(),
           py::arg("tolerance") = py::none(), py::arg("damping_ratio") = py::none(), py::arg("newton") = py::none(),
           py::arg("preconditioner") = py::none())
      .def_property_readonly("time", [](const PySimulation& s) { return s.sim().time(); }, "Simulated time (s)")
      .def_property_readonly("dt", [](const PySimulation& s) { return s.sim().scene().integrator.dt; },
                             "The scene's time step (s; for rk45 the largest step)")
      .def_property_readonly("duration", [](const PySimulation& s) { return s.sim().scene().duration; })
      .def_property_readonly("frame_interval", [](const PySimulation& s) { return s.sim().scene().frame_interval; })
      .def_property_readonly("frame_times", &PySimulation::frame_times,
                             "The times of `weft run`'s frames: 0, then every frame interval to the duration")
      .def_property_readonly("method", [](const PySimulation& s) { return s.sim().scene().method_name; })
      .def_property_readonly("vertex_count", &PySimulation::vertex_count)
      .def_property_readonly("energy_scale", [](const PySimulation& s) { return s.sim().energy_scale(); },
                             "The scene's energy scale (J): the initial kinetic + elastic energy + weight times size, or "
                             "the kinetic energy at the colliders' and clamps' fastest speed over 0.1 s, whichever is "
                             "larger; `weft run` stops a run whose energy rises by more than it (docs/scene-format.md)")
      .def("new_run", [](const PySimulation& s) { return std::make_unique<PySimulation>(s.sim().model()); },
           "A new simulation of this one's scene at its start, sharing what the scene defines and no step changes "
           "(the cloth's mesh, a garment's sewing, its elements, the bodies and collider meshes; built once): its "
           "own state, statistics and recording, which this simulation never sees. Cheaper than Simulation(scene) "
           "when the set-up is long (a sewn garment); the keyword settings are this simulation's.")
      .def("step", &PySimulation::step, py::arg("n") = 1,
           "Takes n steps of the scene's dt (rk45: advances by n times dt in adaptive steps)")
      .def("advance", &PySimulation::advance, py::arg("t"),
           "Advances to time t (s), in steps of dt as `weft run` takes them between frames")
      .def_property_readonly(
          "positions",
          [](py::object self) { return PySimulation::view(self.cast<PySimulation&>().sim().positions(), self); },
          "#V by 3 positions (m): a writable numpy view of the simulation's own array (no copy); "
          "steps update it in place")
      .def_property_readonly(
          "velocities",
          [](py::object self) { return PySimulation::view(self.cast<PySimulation&>().sim().velocities(), self); },
          "#V by 3 velocities (m/s): a writable numpy view of the simulation's own array")
      .def_property_readonly(
          "masses",
          [](py::object self) {
            const weft::VecX& m = self.cast<PySimulation&>().sim().masses();
            py::array a(py::dtype::of<double>(), {m.size()}, {static_cast<py::ssize_t>(sizeof(double))}, m.data(), self);
            a.attr("setflags")(py::arg("write") = false);
            return a;
          },
          "Vertex masses (kg), #V, a read-only view")
      .def_property_readonly(
          "triangles",
          [](const PySimulation& s) {
            const auto& t = s.sim().mesh().triangles;
            py::array_t<int> out({static_cast<py::ssize_t>(t.size()), py::ssize_t(3)});
            auto a = out.mutable_unchecked<2>();
            for (size_t f = 0; f < t.size(); ++f)
              for (int c = 0; c < 3; ++c) a(f, c) = t[f][c];
            return out;
          },
          "#F by 3 vertex indices of the cloth's triangles (a copy)")
      .def_property_readonly(
          "pinned",
          [](const PySimulation& s) {
            std::vector<int> pins;
            const auto& fixed = s.sim().pinned();
            for (size_t i = 0; i < fixed.size(); ++i)
              if (fixed[i]) pins.push_back(static_cast<int>(i));
            return py::array_t<int>(static_cast<py::ssize_t>(pins.size()), pins.data());
          },
          "Indices of the pinned vertices")
      .def_property_readonly(
          "added_viscosity",
          [](const PySimulation& s) {
            const weft::VecX eta = s.sim().added_viscosity_per_vertex();
            return py::array_t<double>(eta.size(), eta.data());
          },
          "Per vertex, the viscosity adaptive damping added in the last step (N s/m; a copy)")
      .def_property_readonly(
          "colliders",
          [](const PySimulation& s) {
            py::list l;
            for (size_t k = 0; k < s.sim().collider_count(); ++k)
              l.append(py::dict(py::arg("name") = s.sim().collider(k).name,
                                py::arg("shape") = shape_name(s.sim().collider(k).shape)));
            return l;
          },
          "The scene's colliders in file order: dicts with name and shape")
      .def("energies", &PySimulation::energies,
           "Energies now (J), as energy.csv has them: kinetic, elastic, gravity, viscous_dissipated, "
           "numerical_dissipated, contact_work, fail_safe_work, total, and time")
      .def_property_readonly("statistics", &PySimulation::statistics,
                             "Step statistics since the start: steps, CG iterations and solves, contacts, ... "
                             "(the counts summary.json reports)")
      .def("move_pins", &PySimulation::move_pins, py::arg("vertices"), py::arg("targets"), py::arg("over") = py::none(),
           "Moves pinned vertices in straight lines to targets (#vertices by 3), arriving `over` seconds from now "
           "(default one step; rounded to whole steps), where they stop")
      .def("move_collider", &PySimulation::move_collider, py::arg("index"), py::arg("translation"),
           py::arg("rotation_deg") = weft::Vec3(weft::Vec3::Zero()), py::arg("over") = py::none(),
           "Moves a rigid collider from its pose now to the pose (translation, then rotation by X, Y, Z degrees, "
           "applied to the collider as the scene places it), arriving `over` seconds from now (default one step), "
           "then holds it there")
      .def("collider_pose", &PySimulation::collider_pose, py::arg("index"),
           "The 4 by 4 transform of a rigid collider now (identity: as the scene places it)")
      .def("write_obj", [](const PySimulation& s, const py::object& p) { s.write_obj(path_text(p)); }, py::arg("path"),
           "The cloth now as `weft run`'s OBJ frames (texture coordinates, normals)")
      .def("write_ply", [](const PySimulation& s, const py::object& p) { s.write_ply(path_text(p)); }, py::arg("path"),
           "The cloth now as `weft run`'s PLY frames (with per-vertex added viscosity)")
      .def("write_collider_obj",
           [](const PySimulation& s, long k, const py::object& p) { s.write_collider_obj(k, path_text(p)); },
           py::arg("index"), py::arg("path"), "A collider's surface now, as the frames' body<k>/collider<k> OBJ files")
      .def("record_frame", &PySimulation::record_frame,
           "Keeps the state now as a frame of the run: its energies (energy.csv, summary) and positions (glb, pc2)")
      .def_property_readonly("frames_recorded", &PySimulation::frames_recorded)
      .def_property_readonly("recorded_energies", &PySimulation::recorded_energies,
                             "The energies of the recorded frames, one dict per frame")
      .def("write_energy_csv",
           [](const PySimulation& s, const py::object& p) { s.write_energy_csv(path_text(p)); }, py::arg("path"),
           "energy.csv of the recorded frames")
      .def("write_glb", [](const PySimulation& s, const py::object& p) { s.write_glb(path_text(p)); }, py::arg("path"),
           "An animated glTF binary of the recorded frames (cloth and colliders)")
      .def("write_usda", [](const PySimulation& s, const py::object& p) { s.write_usda(path_text(p)); }, py::arg("path"),
           "A USD ASCII stage of the recorded frames (cloth and colliders, points time-sampled)")
      .def(
          "write_pc2",
          [](const PySimulation& s, const py::object& p, const py::object& rest) {
            s.write_pc2(path_text(p), rest.is_none() ? std::nullopt : std::optional<std::string>(path_text(rest)));
          },
          py::arg("path"), py::arg("rest_path") = py::none(),
          "A PC2 point cache of the recorded frames and its rest mesh (default: PATH's stem + _rest.obj)")
      .def("summary", [](const PySimulation& s) { return to_python(s.summary()); },
           "summary.json's fields for the run so far (its energies: the recorded frames')")
      .def("write_summary", [](const PySimulation& s, const py::object& p) { s.write_summary(path_text(p)); },
           py::arg("path"), "summary.json of the run so far");
}
