// Whole-file reading and all-or-nothing writing.
//
// Every output polyrad writes goes through AtomicFile: the data goes to a temporary file beside
// the target, is flushed, and is renamed over the target only when complete. An interrupted or
// failed run therefore leaves either the old file or none, never half of a new one.
//
//   AtomicFile out("out/image.exr");       // reserves out/.image.exr.<pid>.tmp.exr
//   write_something(out.temp_path());
//   out.commit();                          // rename; the destructor removes it if not committed
#pragma once

#include <string>
#include <string_view>

namespace polyrad {

// Reads a file into a string; throws InputError naming the file (what: "the scene file").
std::string read_text_file(const std::string& path, const char* what);

class AtomicFile {
 public:
  explicit AtomicFile(std::string target);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  // Temporary path that keeps the target's extension (image writers choose format by it).
  const std::string& temp_path() const { return temp_; }
  const std::string& target() const { return target_; }
  // fsyncs the temporary and renames it over the target; throws std::runtime_error on failure
  // (a full disk included).
  void commit();

 private:
  std::string target_;
  std::string temp_;
  bool committed_ = false;
  int slot_ = -1;  // entry in the table of pending temporaries
};

// Writes bytes through an AtomicFile; throws std::runtime_error naming the path on failure.
void write_file_atomic(const std::string& path, std::string_view bytes);

// Every temporary path not yet committed, for the signal handler to remove.
void remove_pending_temporaries() noexcept;

// Creates a directory and its parents; throws InputError if it cannot.
void make_directories(const std::string& path);

}  // namespace polyrad
