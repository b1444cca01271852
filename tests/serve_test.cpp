// `polyrad serve`: the relighter, the in-memory encoders, the API's JSON, and the HTTP server
// in-process (httplib's client) and as a CLI subprocess. Images are compared with what
// `polyrad relight` writes for the same emissions.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <thread>

#include "polyrad/app/relight.h"
#include "polyrad/io/image_encoding.h"
#include "polyrad/io/image_io.h"
#include "polyrad/serve/relight_request.h"
#include "polyrad/serve/relight_server.h"
#include "polyrad/util/files.h"
#include "polyrad/util/json.h"
#include "test_support.h"

// After Eigen (through polyrad's headers): httplib brings <resolv.h>, whose `_res` macro would
// rewrite a parameter name in Eigen's product kernels.
#include <httplib.h>

namespace polyrad::serve {
namespace {

namespace fs = std::filesystem;

std::string read_bytes(const std::string& path) { return read_text_file(path, "a test output"); }

int run_cli(const std::string& args, std::string* err = nullptr) {
  auto dir = test::temp_dir();
  const std::string err_file = (dir / "stderr.txt").string();
  // `timeout`: a server that should have refused to start must not hang the test.
  const std::string cmd = "timeout 300 " + std::string(POLYRAD_CLI) + " --quiet " + args + " 2>" +
                          err_file + " >/dev/null";
  int status = std::system(cmd.c_str());
  if (err) *err = read_bytes(err_file);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// A private copy of a scene with a small, non-square camera and a second lamp on the back wall,
// so that the operators are quick to make and there are two lights to tell apart.
std::string small_scene(const fs::path& dir, const std::string& name) {
  std::string text = read_bytes(test::scene_path(name));
  const std::string camera = "\"width\": 256, \"height\": 256";
  text.replace(text.find(camera), camera.size(), "\"width\": 40, \"height\": 32");
  const std::string light = "{\"name\": \"light\"";
  text.insert(text.find(light),
              "{\"name\": \"lamp2\", \"material\": \"lamp\", \"emission\": [2, 4, 8], \"polygon\": "
              "[[400, 300, 559], [300, 300, 559], [300, 400, 559], [400, 400, 559]]},\n    ");
  for (const char* mesh : {"short_block.obj", "tall_block.obj"})
    test::write_file(dir, std::string("meshes/") + mesh,
                     read_bytes(std::string(POLYRAD_SCENES_DIR) + "/meshes/" + mesh));
  return test::write_file(dir, name + ".json", text);
}

// The operators every test shares, made once: a view one of the Cornell box and a solution
// one of the mirror cube (which can orbit).
struct Operators {
  fs::path dir;
  std::string view_prt, solution_prt;
};

const Operators& operators() {
  static const Operators ops = [] {
    Operators o;
    o.dir = test::temp_dir();
    const std::string box = small_scene(o.dir, "cornell-box");
    const std::string cube = small_scene(o.dir, "cornell-mirror-cube");
    o.view_prt = (o.dir / "view.prt").string();
    o.solution_prt = (o.dir / "solution.prt").string();
    std::string err;
    EXPECT_EQ(
        run_cli("precompute " + box + " -o " + o.view_prt + " --patch-size 150 --order 6", &err), 0)
        << err;
    EXPECT_EQ(
        run_cli(
            "precompute " + cube + " -o " + o.solution_prt +
                " --patch-size 150 --order 6 --output solution --lobe-samples 4 --light-samples 1",
            &err),
        0)
        << err;
    return o;
  }();
  return ops;
}

// A server on a free loopback port, run on a thread of its own.
class TestServer {
 public:
  explicit TestServer(const std::string& prt, ServerOptions o = {})
      : relighter_(std::make_shared<const Relighter>(prt)) {
    o.port = 0;
    server_ = std::make_unique<RelightServer>(relighter_, o);
    port_ = server_->bind();
    thread_ = std::thread([this] { server_->run(); });
  }
  ~TestServer() {
    server_->stop();
    thread_.join();
  }
  int port() const { return port_; }
  const Relighter& relighter() const { return *relighter_; }
  httplib::Client client() const {
    httplib::Client c("127.0.0.1", port_);
    c.set_read_timeout(60);
    return c;
  }

 private:
  std::shared_ptr<const Relighter> relighter_;
  std::unique_ptr<RelightServer> server_;
  int port_ = 0;
  std::thread thread_;
};

httplib::Result post(httplib::Client& c, const std::string& body) {
  return c.Post("/api/relight", body, "application/json");
}

std::string error_of(const httplib::Result& r) {
  if (!r) return "(no answer)";
  JsonValue v = parse_json(r->body, "answer");
  const JsonValue* e = v.find("error");
  return e && e->is(JsonValue::Kind::kString) ? e->string : "(no error key in " + r->body + ")";
}

// Sends raw bytes on a new connection and returns whatever comes back before the server closes
// it (or a second passes); `close_early` hangs up right after sending.
std::string raw_exchange(int port, const std::string& bytes, bool close_early = false) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  EXPECT_EQ(send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL), static_cast<ssize_t>(bytes.size()));
  std::string answer;
  if (!close_early) {
    timeval tv{1, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    char buf[4096];
    for (ssize_t n; (n = recv(fd, buf, sizeof buf, 0)) > 0;)
      answer.append(buf, static_cast<size_t>(n));
  }
  close(fd);
  return answer;
}

// ---- the relighter and the encoders ------------------------------------------------------------

TEST(Serve, RelighterKnowsItsLightsAndRefusesWhatRelightRefuses) {
  const Operators& ops = operators();
  Relighter r(ops.view_prt);
  ASSERT_EQ(r.lights().size(), 2u);
  EXPECT_EQ(r.lights()[0].name, "lamp2");
  EXPECT_TRUE((r.lights()[0].emission == Rgb(2, 4, 8)).all());
  EXPECT_EQ(r.lights()[1].name, "light");
  EXPECT_TRUE((r.lights()[1].emission == Rgb(17, 12, 4)).all());
  EXPECT_EQ(r.width(), 40);
  EXPECT_EQ(r.height(), 32);
  EXPECT_FALSE(r.can_orbit());
  EXPECT_THROW(r.relight({{"lamp", Rgb(1, 1, 1)}}), InputError);
  EXPECT_THROW(r.relight({}, Orbit{10, 0}), InputError);
  const fs::path dir = test::temp_dir();
  EXPECT_THROW(Relighter((dir / "none.prt").string()), InputError);
  EXPECT_THROW(Relighter(test::write_file(dir, "bad.prt", "POLYRADQ garbage")), InputError);
  // Checked against another scene: stale.
  EXPECT_THROW(Relighter(ops.view_prt, test::scene_path("cornell-box")), InputError);
}

TEST(Serve, TonemapTableGivesWhatTheFileWriterGives) {
  const Srgb8Table& t = srgb8_table();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-0.1, 1.2);
  for (int k = 0; k < 200000; ++k) {
    double x = k < 100000 ? u(rng) : std::pow(10.0, -6.0 + 6.0 * (k - 100000) / 100000.0);
    ASSERT_EQ(t(x), to_srgb8(Rgb(x, x, x), 1.0)[0]) << x;
  }
  // Each step and its neighbours, where rounding decides.
  for (int v = 1; v < 256; ++v) {
    double lo = 0.0, hi = 1.0;
    while (hi - lo > 1e-15) {
      double mid = 0.5 * (lo + hi);
      (to_srgb8(Rgb(mid, mid, mid), 1.0)[0] >= v ? hi : lo) = mid;
    }
    for (double x = std::nextafter(lo, -1.0), n = 0; n < 6; ++n, x = std::nextafter(x, 2.0))
      ASSERT_EQ(t(x), to_srgb8(Rgb(x, x, x), 1.0)[0]) << v << " " << x;
  }
}

TEST(Serve, EncodersMatchTheFileWriters) {
  Image img(7, 5);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 3.0f);
  for (float& v : img.rgb) v = u(rng);
  const fs::path dir = test::temp_dir();
  write_image(img, (dir / "a.pfm").string());
  EXPECT_EQ(encode_pfm(img), read_bytes((dir / "a.pfm").string()));
  write_image(img, (dir / "a.png").string(), ImageWriteOptions{0.7});
  for (PngEncoding e : {PngEncoding::kFast, PngEncoding::kCompact}) {
    write_file_atomic((dir / "b.png").string(), encode_png(img, 0.7, e));
    EXPECT_EQ(read_image((dir / "a.png").string()).rgb, read_image((dir / "b.png").string()).rgb);
  }
}

// ---- the API -----------------------------------------------------------------------------------

TEST(Serve, OperatorDescribesLightsSizeAndKind) {
  TestServer s(operators().view_prt);
  auto c = s.client();
  auto r = c.Get("/api/operator");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/json");
  JsonValue v = parse_json(r->body, "operator");
  ASSERT_TRUE(v.find("lights") && v.find("lights")->array.size() == 2) << r->body;
  const JsonValue& light = v.find("lights")->array[1];
  EXPECT_EQ(light.find("name")->string, "light");
  EXPECT_EQ(json_numbers(*light.find("emission"), "emission", 3), (std::vector<double>{17, 12, 4}));
  EXPECT_EQ(v.find("width")->number, 40);
  EXPECT_EQ(v.find("height")->number, 32);
  EXPECT_EQ(v.find("output")->string, "view");
  EXPECT_EQ(v.find("order")->number, 6);
  EXPECT_EQ(v.find("bytes")->number, static_cast<double>(s.relighter().op().bytes()));
  EXPECT_FALSE(v.find("orbit")->boolean);
}

TEST(Serve, PageAndItsFilesComeFromTheBinary) {
  TestServer s(operators().view_prt);
  auto c = s.client();
  auto page = c.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->get_header_value("Content-Type").find("text/html"), std::string::npos);
  EXPECT_NE(page->body.find("/app.js"), std::string::npos);
  for (const char* path : {"/app.js", "/style.css"}) {
    auto r = c.Get(path);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200) << path;
    EXPECT_GT(r->body.size(), 100u) << path;
  }
}

TEST(Serve, PfmIsByteIdenticalToRelight) {
  const Operators& ops = operators();
  TestServer s(ops.view_prt);
  auto c = s.client();
  const fs::path dir = test::temp_dir();
  const std::string mine = (dir / "cli.pfm").string(), scene = (dir / "scene.pfm").string();
  ASSERT_EQ(run_cli("relight " + ops.view_prt + " -o " + mine + " --emission light=5,6.5,0.25"), 0);
  ASSERT_EQ(run_cli("relight " + ops.view_prt + " -o " + scene), 0);
  auto r = post(c, R"({"emission": {"light": [5, 6.5, 0.25]}, "format": "pfm"})");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "image/x-portable-floatmap");
  EXPECT_TRUE(r->body == read_bytes(mine));
  // Lights not named keep their scene emission.
  auto plain = post(c, R"({"format": "pfm"})");
  ASSERT_TRUE(plain);
  EXPECT_TRUE(plain->body == read_bytes(scene));
  EXPECT_FALSE(plain->body == r->body);
}

TEST(Serve, PngHasTheRelightPixelsAndTheProductTime) {
  const Operators& ops = operators();
  TestServer s(ops.view_prt);
  auto c = s.client();
  const fs::path dir = test::temp_dir();
  const std::string mine = (dir / "cli.png").string(), served = (dir / "served.png").string();
  ASSERT_EQ(run_cli("relight " + ops.view_prt + " -o " + mine +
                    " --emission lamp2=0,0,0 --emission light=30,20,10 --exposure 2.5"),
            0);
  auto r = post(c, R"({"emission": {"lamp2": [0, 0, 0], "light": [30, 20, 10]}, "exposure": 2.5})");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "image/png");
  EXPECT_EQ(r->body.substr(1, 3), "PNG");
  write_file_atomic(served, r->body);
  Image a = read_image(mine), b = read_image(served);
  EXPECT_EQ(b.width, 40);
  EXPECT_EQ(b.height, 32);
  EXPECT_EQ(a.rgb, b.rgb);
  const std::string ms = r->get_header_value("X-Polyrad-Product-Ms");
  ASSERT_FALSE(ms.empty());
  EXPECT_GE(std::stod(ms), 0.0);
  EXPECT_LT(std::stod(ms), 1000.0);
  EXPECT_FALSE(r->get_header_value("X-Polyrad-Encode-Ms").empty());
}

TEST(Serve, BadRequestsAre400WithAJsonError) {
  TestServer s(operators().view_prt);
  auto c = s.client();
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "request:"},                   // empty: malformed
      {"{\"emission\": ", "request:1:"},  // malformed JSON
      {"not json", "request:1:1"},
      {"[1, 2]", "must be an object"},
      {R"({"emission": {"lamp": [1, 1, 1]}})", "'lamp' is not a light"},
      {R"({"emission": {"light": [-1, 1, 1]}})", "not negative"},
      {R"({"emission": {"light": [1, 1]}})", "array of 3 numbers"},
      {R"({"emission": {"light": [1, 1, 1, 1]}})", "array of 3 numbers"},
      {R"({"emission": {"light": ["1", 1, 1]}})", "must be a number"},
      {R"({"emission": {"light": [1e999, 1, 1]}})", "request:1:"},  // not finite
      {R"({"emission": {"light": [1, 1, 1], "light": [2, 2, 2]}})", "request:1:"},
      {R"({"emission": [1, 1, 1]})", "'emission' must be an object"},
      {R"({"format": "jpg"})", "'format'"},
      {R"({"format": 3})", "'format'"},
      {R"({"exposure": 0})", "'exposure' must be above 0"},
      {R"({"exposure": -2})", "'exposure' must be above 0"},
      {R"({"exposure": "bright"})", "must be a number"},
      {R"({"colour": 1})", "unknown or unused key 'colour'"},
      {R"({"camera": {"yaw": 10}})", "camera is fixed"},
      {std::string(300, '[') + std::string(300, ']'), "nesting"},
      {R"({"emission": {"light": [1e300, 1e300, 1e300]}})", "non-finite"},  // overflows a float
  };
  for (const auto& [body, says] : cases) {
    auto r = post(c, body);
    ASSERT_TRUE(r) << body;
    EXPECT_EQ(r->status, 400) << body;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/json") << body;
    EXPECT_NE(error_of(r).find(says), std::string::npos) << body << " -> " << error_of(r);
  }
}

TEST(Serve, LargeBodiesAre413AndUnknownPathsAre404) {
  TestServer s(operators().view_prt);
  auto c = s.client();
  auto big = post(c, "{\"emission\": {}, \"pad\": \"" + std::string(1 << 20, 'x') + "\"}");
  ASSERT_TRUE(big);
  EXPECT_EQ(big->status, 413);
  EXPECT_FALSE(error_of(big).empty());
  // Just under the limit is read (and refused for its unknown key, not its size).
  std::string under = "{\"pad\": \"" + std::string((1 << 20) - 20, 'x') + "\"}";
  ASSERT_LE(under.size(), std::size_t(1) << 20);
  auto ok = post(c, under);
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->status, 400);
  for (const char* path : {"/nope", "/api", "/api/operator/x", "/index.html", "/app.js/"}) {
    auto r = c.Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 404) << path;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/json") << path;
    EXPECT_FALSE(error_of(r).empty());
  }
  auto p = c.Post("/api/operator", "{}", "application/json");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->status, 404);
  EXPECT_FALSE(error_of(p).empty());
  auto g = c.Get("/api/relight");
  ASSERT_TRUE(g);
  EXPECT_EQ(g->status, 405);
}

TEST(Serve, PathTraversalFindsNothing) {
  TestServer s(operators().view_prt);
  for (const char* path :
       {"/../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/..%2f..%2fetc%2fpasswd",
        "/%2e%2e%2f%2e%2e%2fetc%2fpasswd", "//etc/passwd", "/./app.js/../../../etc/passwd",
        "/..\\..\\etc\\passwd"}) {
    std::string answer = raw_exchange(
        s.port(), std::string("GET ") + path + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    EXPECT_EQ(answer.rfind("HTTP/1.1 404", 0), 0u) << path << "\n" << answer.substr(0, 200);
    EXPECT_EQ(answer.find("root:"), std::string::npos) << path;
  }
}

TEST(Serve, EightConcurrentClientsGetTheirOwnImages) {
  const Operators& ops = operators();
  for (bool serialise : {true, false}) {
    ServerOptions o;
    o.serialise_products = serialise;
    TestServer s(ops.view_prt, o);
    // The expected image of each client, from the relighter directly.
    auto body = [](int k) {
      return "{\"emission\": {\"light\": [" + std::to_string(k + 1) +
             ", 2, 3]}, \"format\": \"pfm\"}";
    };
    std::vector<std::string> expected;
    for (int k = 0; k < 8; ++k)
      expected.push_back(encode_pfm(s.relighter().relight({{"light", Rgb(k + 1, 2, 3)}}).image));
    std::atomic<int> good{0};
    std::vector<std::thread> clients;
    for (int k = 0; k < 8; ++k)
      clients.emplace_back([&, k] {
        auto c = s.client();
        for (int n = 0; n < 12; ++n) {
          auto r = post(c, body(k));
          if (r && r->status == 200 && r->body == expected[k]) ++good;
        }
      });
    for (auto& t : clients) t.join();
    EXPECT_EQ(good.load(), 8 * 12) << "serialise " << serialise;
  }
}

TEST(Serve, ClientsThatHangUpLeaveTheServerServing) {
  TestServer s(operators().view_prt);
  const std::string body = R"({"emission": {"light": [1, 2, 3]}})";
  // Headers promising a body that never comes; half a request line; a whole request whose
  // answer nobody reads; many of them at once.
  for (int k = 0; k < 4; ++k) {
    raw_exchange(s.port(),
                 "POST /api/relight HTTP/1.1\r\nHost: x\r\nContent-Length: 1000\r\n\r\n{\"emi",
                 true);
    raw_exchange(s.port(), "GET /api/oper", true);
    raw_exchange(s.port(),
                 "POST /api/relight HTTP/1.1\r\nHost: x\r\nContent-Length: " +
                     std::to_string(body.size()) + "\r\n\r\n" + body,
                 true);
  }
  std::vector<std::thread> hangups;
  for (int k = 0; k < 16; ++k)
    hangups.emplace_back([&] {
      raw_exchange(s.port(),
                   "POST /api/relight HTTP/1.1\r\nHost: x\r\nContent-Length: " +
                       std::to_string(body.size()) + "\r\n\r\n" + body,
                   true);
    });
  for (auto& t : hangups) t.join();
  auto c = s.client();
  auto r = post(c, body);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  // A malformed request line gets an answer and the server goes on.
  EXPECT_EQ(raw_exchange(s.port(), "BOGUS\r\n\r\n").rfind("HTTP/1.1 400", 0), 0u);
  EXPECT_EQ(c.Get("/api/operator")->status, 200);
}

// ---- solution operators: any camera ------------------------------------------------------------

TEST(Serve, SolutionOperatorsOrbitTheCamera) {
  const Operators& ops = operators();
  TestServer s(ops.solution_prt);
  auto c = s.client();
  auto op = c.Get("/api/operator");
  ASSERT_TRUE(op);
  JsonValue v = parse_json(op->body, "operator");
  EXPECT_EQ(v.find("output")->string, "solution");
  EXPECT_TRUE(v.find("orbit")->boolean);
  EXPECT_EQ(v.find("width")->number, 40);
  // The scene camera: the image `relight` writes.
  const fs::path dir = test::temp_dir();
  const std::string mine = (dir / "cli.pfm").string();
  ASSERT_EQ(run_cli("relight " + ops.solution_prt + " -o " + mine + " --emission light=9,9,9"), 0);
  auto front = post(
      c,
      R"({"emission": {"light": [9, 9, 9]}, "format": "pfm", "camera": {"yaw": 0, "pitch": 0}})");
  ASSERT_TRUE(front);
  ASSERT_EQ(front->status, 200) << front->body;
  EXPECT_TRUE(front->body == read_bytes(mine));
  EXPECT_EQ(front->get_header_value("X-Polyrad-Gather-Built"), "0");  // built at start
  // Another camera: a new gather, a different image; the same camera again: cached.
  const std::string turned =
      R"({"emission": {"light": [9, 9, 9]}, "format": "pfm", "camera": {"yaw": 20, "pitch": 10}})";
  auto a = post(c, turned);
  ASSERT_TRUE(a);
  ASSERT_EQ(a->status, 200) << a->body;
  EXPECT_EQ(a->get_header_value("X-Polyrad-Gather-Built"), "1");
  EXPECT_FALSE(a->body == front->body);
  auto b = post(c, turned);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->get_header_value("X-Polyrad-Gather-Built"), "0");
  EXPECT_TRUE(a->body == b->body);
  auto bad = post(c, R"({"camera": {"yaw": 1, "roll": 2}})");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
}

TEST(Serve, OrbitTurnsAboutTheLookAtPoint) {
  Camera cam;
  cam.position = Vec3(0, 0, -10);
  cam.look_at = Vec3(0, 0, 0);
  Camera same = orbit_camera(cam, {});
  EXPECT_LT((same.position - cam.position).norm(), 1e-12);
  Camera side = orbit_camera(cam, {90, 0});
  EXPECT_NEAR((side.position - cam.look_at).norm(), 10.0, 1e-9);
  EXPECT_NEAR(std::abs(side.position.x()), 10.0, 1e-9);
  Camera up = orbit_camera(cam, {0, 200});  // held short of the pole
  EXPECT_NEAR(up.position.y(), 10.0 * std::sin(85.0 * M_PI / 180.0), 1e-9);
  EXPECT_EQ(up.look_at, cam.look_at);
}

// ---- the command line ------------------------------------------------------------------------

struct Child {
  pid_t pid = -1;
  int err_fd = -1;
};

// Starts `polyrad serve ARGS` with stderr on a pipe.
Child spawn_serve(const std::vector<std::string>& args) {
  int fds[2];
  EXPECT_EQ(pipe(fds), 0);
  Child c;
  c.pid = fork();
  if (c.pid == 0) {
    dup2(fds[1], 2);
    close(fds[0]);
    close(fds[1]);
    std::vector<std::string> all = {POLYRAD_CLI, "--quiet", "serve"};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(POLYRAD_CLI, argv.data());
    _exit(127);
  }
  close(fds[1]);
  c.err_fd = fds[0];
  return c;
}

// Reads stderr until a whole line arrives (or the child ends).
std::string read_line(int fd) {
  std::string line;
  char ch;
  while (read(fd, &ch, 1) == 1 && ch != '\n') line += ch;
  return line;
}

int wait_exit(pid_t pid) {
  int status = 0;
  for (int k = 0; k < 200; ++k) {  // 20 s at most
    if (waitpid(pid, &status, WNOHANG) == pid)
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return -1;
}

TEST(Serve, CliPrintsItsAddressAndStopsCleanlyOnSignals) {
  for (int sig : {SIGTERM, SIGINT}) {
    Child c = spawn_serve({operators().view_prt, "--port", "0"});
    const std::string line = read_line(c.err_fd);
    const std::string prefix = "polyrad: serving http://127.0.0.1:";
    ASSERT_EQ(line.rfind(prefix, 0), 0u) << line;
    const int port = std::stoi(line.substr(prefix.size()));
    EXPECT_EQ(line, prefix + std::to_string(port) + "/");
    httplib::Client client("127.0.0.1", port);
    auto r = client.Get("/api/operator");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200);
    kill(c.pid, sig);
    EXPECT_EQ(wait_exit(c.pid), 0) << "signal " << sig;
    close(c.err_fd);
  }
}

TEST(Serve, CliRefusesBadArgumentsWithExitTwo) {
  const fs::path dir = test::temp_dir();
  const std::string prt = operators().view_prt;
  const std::string damaged = test::write_file(dir, "damaged.prt", "POLYRADQ garbage");
  // A port that is taken.
  httplib::Server blocker;
  const int taken = blocker.bind_to_any_port("127.0.0.1");
  for (const std::string& args :
       std::vector<std::string>{"serve " + (dir / "none.prt").string(), "serve " + damaged,
                                "serve " + prt + " --port 70000", "serve " + prt + " --port -1",
                                "serve " + prt + " --port x", "serve",
                                "serve " + prt + " --scene " + test::scene_path("cornell-box"),
                                "serve " + prt + " --port " + std::to_string(taken),
                                "serve " + prt + " --host 203.0.113.9 --port 0"}) {
    std::string err;
    EXPECT_EQ(run_cli(args, &err), 2) << args << "\n" << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << args << "\n" << err;
  }
}

}  // namespace
}  // namespace polyrad::serve
