// The polyrad command line: thin subcommands over the library.
#include <omp.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>

#include "flags.h"
#include "polyrad/util/files.h"
#include "polyrad/util/machine.h"
#include "polyrad/util/progress.h"

namespace {

void on_signal(int sig) {
  // Leave nothing half-written: remove the temporaries of unfinished outputs, then die.
  polyrad::remove_pending_temporaries();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace polyrad::cli;
  polyrad::return_large_blocks_to_the_system();
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGHUP, on_signal);
  // A file size limit (or a full disk) must surface as a write error that is reported, not as a
  // signal that kills the process with a half-written temporary.
  std::signal(SIGXFSZ, SIG_IGN);

  CLI::App app{"polyrad: glossy radiosity with a precomputed transport polynomial"};
  app.require_subcommand(1);
  int threads = 0;
  bool quiet = false;
  app.add_option("--threads", threads, "OpenMP threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_flag("--quiet", quiet, "No progress display");
  app.parse_complete_callback([&] {
    if (threads > 0) omp_set_num_threads(threads);
    if (quiet) polyrad::Progress::set_enabled(false);
  });
  int exit_code = kExitOk;
  add_render_command(app, exit_code);
  add_demo_command(app, exit_code);
  add_compare_command(app, exit_code);
  add_precompute_command(app, exit_code);
  add_relight_command(app, exit_code);
  add_convergence_command(app, exit_code);
  add_sweep_command(app, exit_code);
  add_serve_command(app, exit_code);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "polyrad: error: %s (see polyrad --help)\n", e.what());
    return kExitBadInput;
  } catch (const polyrad::InputError& e) {
    std::fprintf(stderr, "polyrad: error: %s\n", e.what());
    return kExitBadInput;
  } catch (const polyrad::NumericalError& e) {
    std::fprintf(stderr, "polyrad: numerical failure: %s\n", e.what());
    return kExitNumerical;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "polyrad: failed: %s\n", e.what());
    return kExitFailure;
  }
  return exit_code;
}
