#pragma once
// Subcommands register themselves here, so each lives in its own file under app/.
// A command's run function returns the process exit status:
//   0 success, 1 internal error (a bug), 2 bad input (nothing written), 3 the simulation
//   became unstable, 4 an output could not be written (the message names it and says what
//   was kept), 5 `weft check` found intersecting triangles, 6 a garment did not sew (a stitch
//   left open or an intersection left: `weft garment` keeps it as garment_unsewn.obj, `weft run`
//   refuses the scene), 130 interrupted by Ctrl-C or SIGTERM (outputs so far and a checkpoint kept).
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace weft::app {

constexpr int kExitOk = 0;
constexpr int kExitBadInput = 2;
constexpr int kExitUnstable = 3;
constexpr int kExitOutputFailed = 4;
constexpr int kExitIntersections = 5;
constexpr int kExitNotSewn = 6;
constexpr int kExitInterrupted = 130;  ///< 128 + SIGINT, as shells report a Ctrl-C

struct CommandSpec {
  std::string parent;  ///< "" for top level, e.g. "experiment" for `weft experiment NAME`
  std::string name;
  std::string help;
  /// Adds options to `sub`; returns the function to run once parsing succeeded.
  std::function<std::function<int()>(CLI::App& sub)> setup;
  int order = 100;  ///< position in --help listings
};

std::vector<CommandSpec>& command_registry();

struct RegisterCommand {
  explicit RegisterCommand(CommandSpec spec) { command_registry().push_back(std::move(spec)); }
};

}  // namespace weft::app
