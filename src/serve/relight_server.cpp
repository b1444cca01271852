// The relighting server (relight_server.h) on cpp-httplib.
#include "polyrad/serve/relight_server.h"

// httplib after Eigen (through the header above): its <resolv.h> defines a `_res` macro that
// would rewrite a parameter name in Eigen's product kernels.
#include <httplib.h>
#include <sys/socket.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <mutex>
#include <thread>

#include "polyrad/io/image_encoding.h"
#include "polyrad/serve/relight_request.h"
#include "polyrad/util/error.h"
#include "polyrad/util/timer.h"
#include "serve_assets.h"  // generated from src/serve/assets by cmake/EmbedAssets.cmake

namespace polyrad::serve {

namespace {

std::string milliseconds(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f", 1e3 * seconds);
  return text;
}

void set_error(httplib::Response& res, int status, std::string_view message) {
  res.status = status;
  res.set_content(error_json(message), "application/json");
}

// What a status means, for the errors httplib finds before any handler (404, 413, ...).
std::string status_message(int status) {
  switch (status) {
    case 404:
      return "no such resource";
    case 413:
      return "the request body is too large";
    case 400:
      return "malformed HTTP request";
    case 405:
      return "method not allowed";
    default:
      return "HTTP status " + std::to_string(status);
  }
}

// A client that hangs up while its answer is written must not end the process (httplib sends
// without MSG_NOSIGNAL). A handler someone else installed is left alone.
void ignore_sigpipe() {
  struct sigaction current {};
  if (sigaction(SIGPIPE, nullptr, &current) == 0 && current.sa_handler == SIG_DFL)
    std::signal(SIGPIPE, SIG_IGN);
}

// The page's files, found by their exact path in the compiled-in table: nothing else is served,
// so no request path can reach the disk.
const assets::Asset* find_asset(const std::string& path) {
  for (const assets::Asset& a : assets::kAssets)
    if (path == a.path) return &a;
  return nullptr;
}

}  // namespace

struct RelightServer::Impl {
  std::shared_ptr<const Relighter> relighter;
  ServerOptions options;
  httplib::Server server;
  std::mutex product_mutex;  // with serialise_products: one product at a time
  std::atomic<bool> stopping{false}, in_run{false};

  void get_asset(const httplib::Request& req, httplib::Response& res) const {
    const assets::Asset* a = find_asset(req.path);
    if (!a) return set_error(res, 404, "no such resource: " + req.path);
    res.set_content(reinterpret_cast<const char*>(a->data), a->size, a->type);
    res.set_header("Cache-Control", "no-cache");
  }

  void get_operator(httplib::Response& res) const {
    res.set_content(operator_json(*relighter), "application/json");
  }

  Relit relight_locked(const RelightRequest& r) {
    std::unique_lock<std::mutex> lock(product_mutex, std::defer_lock);
    if (options.serialise_products) lock.lock();
    return relighter->relight(r.emission, r.orbit);
  }

  void post_relight(const httplib::Request& req, httplib::Response& res) {
    const Stopwatch watch;
    RelightRequest r;
    Relit relit;
    try {
      r = parse_relight_request(req.body, *relighter);
      relit = relight_locked(r);
    } catch (const InputError& e) {
      return set_error(res, 400, e.what());
    } catch (const NumericalError& e) {  // emissions so large that the image overflows a float
      return set_error(res, 400, e.what());
    }
    const double encode_start = watch.seconds();
    const bool png = r.format == ImageFormat::kPng;
    res.set_content(png ? encode_png(relit.image, r.exposure) : encode_pfm(relit.image),
                    png ? "image/png" : "image/x-portable-floatmap");
    res.set_header("X-Polyrad-Product-Ms", milliseconds(relit.product_seconds));
    res.set_header("X-Polyrad-Encode-Ms", milliseconds(watch.seconds() - encode_start));
    if (relighter->can_orbit()) {
      res.set_header("X-Polyrad-Gather-Ms", milliseconds(relit.gather_seconds));
      res.set_header("X-Polyrad-Gather-Built", relit.gather_built ? "1" : "0");
    }
    res.set_header("X-Polyrad-Server-Ms", milliseconds(watch.seconds()));
    res.set_header("Cache-Control", "no-store");
  }

  void routes() {
    server.Get("/api/operator",
               [this](const httplib::Request&, httplib::Response& res) { get_operator(res); });
    server.Post("/api/relight", [this](const httplib::Request& req, httplib::Response& res) {
      post_relight(req, res);
    });
    server.Get("/api/relight", [](const httplib::Request&, httplib::Response& res) {
      set_error(res, 405, "POST a JSON request to /api/relight");
    });
    server.Get(
        ".*", [this](const httplib::Request& req, httplib::Response& res) { get_asset(req, res); });
  }

  void error_handlers() {
    // Errors without a body of their own (httplib's 404, 413, ...) get one in JSON.
    server.set_error_handler(
        httplib::Server::HandlerWithResponse([](const httplib::Request&, httplib::Response& res) {
          if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
          set_error(res, res.status, status_message(res.status));
          return httplib::Server::HandlerResponse::Handled;
        }));
    server.set_exception_handler(
        [](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
          std::string what = "internal error";
          try {
            std::rethrow_exception(ep);
          } catch (const std::exception& e) {
            what = std::string("internal error: ") + e.what();
          } catch (...) {
          }
          set_error(res, 500, what);
        });
  }

  void configure() {
    const int threads = options.threads;
    server.new_task_queue = [threads] {
      return new httplib::ThreadPool(static_cast<size_t>(threads));
    };
    server.set_payload_max_length(options.max_body_bytes);
    server.set_keep_alive_timeout(options.keep_alive_seconds);
    server.set_keep_alive_max_count(1000);  // a page moving a slider sends hundreds
    server.set_tcp_nodelay(true);           // headers and body leave at once (no Nagle wait)
    // httplib's default also sets SO_REUSEPORT, with which a second server on a port in use
    // would start and share its connections; SO_REUSEADDR alone still allows a quick restart.
    server.set_socket_options([](socket_t sock) {
      int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    server.set_default_headers(
        {{"X-Content-Type-Options", "nosniff"},
         {"Content-Security-Policy", "default-src 'self'; img-src 'self' blob:"}});
    routes();
    error_handlers();
  }
};

RelightServer::RelightServer(std::shared_ptr<const Relighter> relighter, ServerOptions options)
    : impl_(std::make_unique<Impl>()) {
  POLYRAD_CHECK(relighter != nullptr);
  impl_->relighter = std::move(relighter);
  impl_->options = std::move(options);
  ignore_sigpipe();
  // The PNG writer's plugin loads, and the tonemap's table is made, before the first request.
  encode_png(Image(1, 1), 1.0);
  impl_->configure();
}

RelightServer::~RelightServer() { stop(); }

int RelightServer::bind() {
  const ServerOptions& o = impl_->options;
  if (o.port < 0 || o.port > 65535) throw InputError("--port must be within 0..65535");
  int port = o.port;
  if (o.port == 0)
    port = impl_->server.bind_to_any_port(o.host);
  else if (!impl_->server.bind_to_port(o.host, o.port))
    port = -1;
  if (port <= 0)
    throw InputError("cannot listen on " + o.host + ":" + std::to_string(o.port) +
                     " (the port is in use, or the host is not an address of this machine)");
  return port;
}

void RelightServer::run() {
  impl_->in_run = true;
  if (!impl_->stopping) impl_->server.listen_after_bind();
  impl_->in_run = false;
}

void RelightServer::stop() {
  impl_->stopping = true;
  // run() may be between its check and httplib's start: wait until it listens or returns.
  while (impl_->in_run && !impl_->server.is_running())
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  impl_->server.stop();
}

}  // namespace polyrad::serve
