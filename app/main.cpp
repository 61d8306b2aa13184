// The `weft` command: a thin shell over the library. Subcommands live in app/cmd_*.cpp.
#include <algorithm>
#include <iostream>
#include <map>

#include "command.hpp"
#include "weft/error.hpp"
#include "weft/threads.hpp"

namespace weft::app {
std::vector<CommandSpec>& command_registry() {
  static std::vector<CommandSpec> registry;
  return registry;
}
}  // namespace weft::app

int main(int argc, char** argv) {
  using namespace weft::app;
  CLI::App app{
      "weft " WEFT_VERSION
      " - cloth simulation by semi-implicit integration (alpha family, Implicit Midpoint,\n"
      "progressive BDF-2) with adaptive damping.\n"
      "Exit status: 0 success, 1 internal error, 2 bad input (nothing written), 3 simulation became\n"
      "unstable, 4 an output could not be written (the message says what was kept), 5 `weft check`\n"
      "found intersections, 6 a garment did not sew (a stitch left open or an intersection left; `weft garment`\n"
      "keeps it as garment_unsewn.obj, `weft run` refuses the scene), 7 `weft sweep`: some runs did not end ok\n"
      "(each has its row), 130 interrupted (Ctrl-C; `weft run` keeps a checkpoint to resume from, `weft sweep` its\n"
      "finished runs)."};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("weft ") + WEFT_VERSION);
  int threads = 0;
  app.add_option("--threads", threads,
                 "Threads for the parallel parts of a step (0: every core, the default); the results are "
                 "the same bits at every count. May also follow the subcommand")
      ->check(CLI::Range(0, 4096));
  app.fallthrough();  // `weft run --threads 1 ...` as well as `weft --threads 1 run ...`

  auto specs = command_registry();
  std::stable_sort(specs.begin(), specs.end(),
                   [](const CommandSpec& a, const CommandSpec& b) { return a.order < b.order; });
  std::map<std::string, CLI::App*> parents;
  std::function<int()> action;
  // Top-level commands first, then groups (e.g. `experiment`) with their members.
  auto add = [&](CLI::App& owner, const CommandSpec& s) {
    CLI::App* sub = owner.add_subcommand(s.name, s.help);
    auto run = s.setup(*sub);
    sub->callback([run, &action] { action = run; });
  };
  for (const auto& s : specs)
    if (s.parent.empty()) add(app, s);
  for (const auto& s : specs) {
    if (s.parent.empty()) continue;
    if (!parents.count(s.parent)) {
      auto* group = app.add_subcommand(s.parent, "Reproducible experiments (see `weft " + s.parent + " --help`)");
      group->require_subcommand(1);
      parents[s.parent] = group;
    }
    add(*parents[s.parent], s);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int code = app.exit(e);
    return code == 0 ? 0 : kExitBadInput;
  }
  try {
    weft::set_thread_count(threads);
    return action ? action() : kExitOk;
  } catch (const weft::SewingError& e) {
    std::cerr << "weft: error: " << e.what() << "\n";
    return kExitNotSewn;
  } catch (const weft::InputError& e) {
    std::cerr << "weft: error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "weft: internal error: " << e.what() << "\n";
    return 1;
  }
}
