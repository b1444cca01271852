#include "polyrad/util/files.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "polyrad/util/error.h"

namespace polyrad {

namespace {

// Temporaries alive right now, so that a signal handler can delete them. A fixed table of
// C strings: the handler must not allocate or lock.
constexpr int kMaxPending = 64;
char g_pending[kMaxPending][4096];
std::atomic<bool> g_used[kMaxPending];
std::mutex g_register_mutex;

int register_pending(const std::string& path) {
  std::lock_guard<std::mutex> lock(g_register_mutex);
  for (int n = 0; n < kMaxPending; ++n) {
    if (!g_used[n].load()) {
      std::snprintf(g_pending[n], sizeof g_pending[n], "%s", path.c_str());
      g_used[n].store(true);
      return n;
    }
  }
  return -1;
}

void unregister_pending(int slot) {
  if (slot >= 0) g_used[slot].store(false);
}

std::string errno_text() { return std::strerror(errno); }

}  // namespace

std::string read_text_file(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(SourceLocation{path}, std::string("cannot open ") + what);
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError(SourceLocation{path}, std::string("cannot read ") + what);
  return ss.str();
}

AtomicFile::AtomicFile(std::string target) : target_(std::move(target)) {
  std::filesystem::path p(target_);
  std::string dir = p.parent_path().string();
  if (dir.empty()) dir = ".";
  temp_ = dir + "/." + p.stem().string() + "." + std::to_string(::getpid()) + ".tmp" +
          p.extension().string();
  slot_ = register_pending(temp_);
}

AtomicFile::~AtomicFile() {
  if (!committed_) std::remove(temp_.c_str());
  unregister_pending(slot_);
}

void AtomicFile::commit() {
  int fd = ::open(temp_.c_str(), O_RDONLY);
  if (fd < 0) throw std::runtime_error("cannot reopen " + temp_ + ": " + errno_text());
  int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) throw std::runtime_error("cannot flush " + target_ + ": " + errno_text());
  if (std::rename(temp_.c_str(), target_.c_str()) != 0)
    throw std::runtime_error("cannot write " + target_ + ": " + errno_text());
  committed_ = true;
}

void write_file_atomic(const std::string& path, std::string_view bytes) {
  AtomicFile file(path);
  {
    std::FILE* f = std::fopen(file.temp_path().c_str(), "wb");
    if (!f) throw std::runtime_error("cannot create " + path + ": " + errno_text());
    size_t written = std::fwrite(bytes.data(), 1, bytes.size(), f);
    int flush_rc = std::fflush(f);
    int close_rc = std::fclose(f);
    if (written != bytes.size() || flush_rc != 0 || close_rc != 0)
      throw std::runtime_error("cannot write " + path + ": " + errno_text());
  }
  file.commit();
}

void remove_pending_temporaries() noexcept {
  for (int n = 0; n < kMaxPending; ++n)
    if (g_used[n].load()) ::unlink(g_pending[n]);
}

void make_directories(const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec) throw InputError(SourceLocation{path}, "cannot create directory: " + ec.message());
}

}  // namespace polyrad
