// polyrad serve: the relighting page for one operator (polyrad/serve/relight_server.h).
#include <pthread.h>

#include <csignal>
#include <cstdio>
#include <memory>
#include <thread>

#include "flags.h"
#include "polyrad/app/relight.h"
#include "polyrad/serve/relight_server.h"

namespace polyrad::cli {

namespace {

struct ServeFlags {
  std::string prt, scene, host = "127.0.0.1";
  int port = 8000;
};

sigset_t stop_signals() {
  sigset_t set;
  sigemptyset(&set);
  for (int s : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&set, s);
  return set;
}

bool is_loopback(const std::string& host) {
  return host == "localhost" || host.rfind("127.", 0) == 0 || host == "::1";
}

int run_serve(const ServeFlags& f) {
  // SIGINT, SIGTERM and SIGHUP stop the server cleanly (exit 0) instead of ending the process:
  // blocked here, before any thread exists, so that every thread inherits the mask and only
  // the waiter below receives them.
  const sigset_t signals = stop_signals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  auto relighter = std::make_shared<const Relighter>(f.prt, f.scene);
  serve::ServerOptions options;
  options.host = f.host;
  options.port = f.port;
  serve::RelightServer server(relighter, options);
  const int port = server.bind();
  if (!is_loopback(f.host))
    std::fprintf(stderr,
                 "polyrad: warning: serving on %s: anyone who can reach this machine can use it\n",
                 f.host.c_str());
  const std::string shown =
      f.host.find(':') != std::string::npos ? "[" + f.host + "]" : f.host;  // IPv6
  std::fprintf(stderr, "polyrad: serving http://%s:%d/\n", shown.c_str(), port);
  std::thread waiter([&server, signals] {
    int sig = 0;
    sigwait(&signals, &sig);
    server.stop();
  });
  server.run();
  // run() returns after stop(); should it ever return on its own, wake the waiter.
  pthread_kill(waiter.native_handle(), SIGTERM);
  waiter.join();
  std::fprintf(stderr, "polyrad: stopped\n");
  return kExitOk;
}

}  // namespace

void add_serve_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<ServeFlags>();
  CLI::App* cmd =
      app.add_subcommand("serve", "Serve a page that relights the operator as you move its lights");
  cmd->add_option("operator", f->prt, "Operator file (.prt)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--scene", f->scene, "The scene, if it moved since the precompute");
  cmd->add_option("--host", f->host, "Address to listen on (loopback by default)")
      ->capture_default_str();
  cmd->add_option("--port", f->port, "Port to listen on (0: any free port, printed)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  cmd->callback([f, &exit_code] { exit_code = run_serve(*f); });
}

}  // namespace polyrad::cli
