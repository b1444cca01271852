// The relighting page and its API over HTTP (cpp-httplib): `polyrad serve FILE.prt`.
//
//   GET  /               the page (index.html, app.js, style.css, compiled into the binary)
//   GET  /api/operator   the lights, image size, output kind, order and bytes (JSON)
//   POST /api/relight    {"emission": {...}, "exposure": E, "format": "png"|"pfm", "camera": {...}}
//                        -> the image; X-Polyrad-Product-Ms gives the product's time
// Errors answer JSON {"error": "..."}: 400 for a bad request (relight_request.h), 404 for any
// other path (nothing is ever read from the disk), 413 for a body over max_body_bytes.
//
//   auto relighter = std::make_shared<const Relighter>("out/scene.prt");
//   RelightServer server(relighter, {.port = 0});
//   int port = server.bind();          // listening from here on
//   std::thread t([&] { server.run(); });
//   ...
//   server.stop();                     // any thread, a signal-waiting one included
//   t.join();
//
// Threads: connections are served by a pool of `threads`, each request on its own thread; the
// relighter is thread-safe, so products (themselves OpenMP-parallel) run concurrently. On the
// 2-core machine, with 4 clients and other work running, that gave 0.84 to 1.16 times (median
// 1.08 over 11 runs) the images a second of products one at a time under a mutex
// (serialise_products), whose holder, when the scheduler parks it, stalls every other request.
// The server ignores SIGPIPE (a client that hangs up mid-answer must not end the process).
// Cost: a relight request is the product, the PNG encoding (image_encoding.h) and the copy to
// the socket; the page itself is a few kilobytes.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "polyrad/app/relight.h"

namespace polyrad::serve {

struct ServerOptions {
  std::string host = "127.0.0.1";        // loopback unless told otherwise
  int port = 8000;                       // 0: any free port (bind() returns it)
  std::size_t max_body_bytes = 1 << 20;  // larger request bodies get 413
  int threads = 8;                       // connections served at once
  bool serialise_products = false;       // true: one product at a time (see above)
  int keep_alive_seconds = 2;            // how long an idle connection is kept (and how long
                                         // stop() may wait for one to notice)
};

class RelightServer {
 public:
  RelightServer(std::shared_ptr<const Relighter> relighter, ServerOptions options = {});
  ~RelightServer();
  RelightServer(const RelightServer&) = delete;
  RelightServer& operator=(const RelightServer&) = delete;

  // Binds and listens; returns the port. Throws InputError if the address cannot be used.
  int bind();
  // Serves until stop(). Call after bind(), once.
  void run();
  // Makes run() return once the requests in progress are answered; from any thread, any time.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace polyrad::serve
