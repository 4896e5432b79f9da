// Deterministic fuzz driver: runs a libFuzzer harness (LLVMFuzzerTestOneInput, one per
// test/fuzz/fuzz_<name>.cpp) without libFuzzer, so that every harness builds with gcc, runs under
// the sanitizers in `scripts/test --sanitize` and reproduces exactly from a seed.
//
//   test_fuzz_<name> [--runs N] [--seed S] [--only I] [--max-len BYTES] [--artifacts DIR]
//               [--dict FILE] [--timeout-s T] [--rss-limit-mb M] [--xml FILE] [--quiet]
//               [--regressions DIR]... [--corpus DIR]... [FILE_OR_DIR]...
//
// Order: every file of the regression folders first (test/fuzz/regressions/<name>/: inputs that
// once failed; each must pass), then the seed corpus (test/fuzz/corpus/<name>/, plus any
// FILE_OR_DIR given), then N mutated inputs (default 10000; --runs 0: replay only). Mutated input
// i is a stack of 1-8 mutations of one corpus input (bit flips, random bytes, inserts, deletes,
// duplicated or spliced ranges from another corpus input, "interesting" integers and floats,
// dictionary tokens, numbers in text replaced by edge-case numbers), drawn from a random stream
// seeded by (S, i) alone: `--seed S --only I` regenerates input i without the others.
//
// A failure - a sanitizer report, a crash, an uncaught exception, a timeout, the RSS limit - prints
// the seed and the input index (or the replayed file) and writes the input to
// ARTIFACTS/crash-<name>-seed<S>-input<I> (or -<file>) for test/fuzz/regressions/<name>/.
// Exit status 0 when every input passed. --xml writes a JUnit file (catkin's test results).
// The harness's documented exceptions are its own business: it catches them; anything that
// reaches the driver is a failure.

#include <dirent.h>
#include <dlfcn.h>
#include <fcntl.h>
#include <link.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

#ifndef DPP_FUZZ_NAME
#error "DPP_FUZZ_NAME (the harness's name) must be defined"
#endif
#ifndef DPP_FUZZ_DIR
#error "DPP_FUZZ_DIR (test/fuzz of the source tree) must be defined"
#endif

namespace {

using Bytes = std::vector<uint8_t>;
const char* const kName = DPP_FUZZ_NAME;

struct Options {
  uint64_t runs = 10000;
  uint64_t seed = 1;
  int64_t only = -1;
  size_t max_len = 0;  // 0: twice the largest corpus input, at least 4096
  std::string artifacts = ".";
  std::vector<std::string> dicts;
  unsigned timeout_s = 0;
  size_t rss_limit_mb = 0;
  std::string xml;
  bool quiet = false;
  std::vector<std::string> regressions, corpus;
  bool default_dirs = true;
};

// ---- the input under test, for the crash handlers ----------------------------------------------
const Bytes* g_current = nullptr;
char g_artifact[4096] = "";
char g_label[512] = "";

/// Async-signal-safe: writes the current input to g_artifact and says so on stderr.
void dumpCurrent() {
  if (!g_current || !g_artifact[0]) return;
  const int fd = open(g_artifact, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd >= 0) {
    size_t done = 0;
    while (done < g_current->size()) {
      const ssize_t n = write(fd, g_current->data() + done, g_current->size() - done);
      if (n <= 0) break;
      done += static_cast<size_t>(n);
    }
    close(fd);
  }
  const char* parts[] = {"\n[fuzz] FAILED on ", g_label, "; input written to ", g_artifact, "\n"};
  for (const char* p : parts)
    if (write(2, p, strlen(p)) < 0) break;
}

void onDeath() { dumpCurrent(); }

void onSignal(int sig) {
  if (sig == SIGALRM) {
    const char m[] = "\n[fuzz] TIMEOUT: the input ran longer than --timeout-s\n";
    if (write(2, m, sizeof m - 1) < 0) {
    }
  }
  dumpCurrent();
  g_current = nullptr;
  signal(sig == SIGALRM ? SIGABRT : sig, SIG_DFL);
  raise(sig == SIGALRM ? SIGABRT : sig);
}

/// Registers onDeath with every sanitizer runtime loaded (called before it exits on a report).
/// gcc links ASan and UBSan as two shared runtimes, each with its own copy of the callback: the
/// one setter the linker would bind covers one of them only, so every loaded object's setter is
/// looked up. Returns whether any sanitizer runtime is present.
bool registerDeathCallbacks() {
  using Setter = void (*)(void (*)(void));
  std::vector<Setter> setters;
  dl_iterate_phdr(
      [](dl_phdr_info* info, size_t, void* out) {
        void* h = dlopen(info->dlpi_name && info->dlpi_name[0] ? info->dlpi_name : nullptr,
                         RTLD_LAZY | RTLD_NOLOAD);
        if (!h) return 0;
        if (void* f = dlsym(h, "__sanitizer_set_death_callback")) {
          auto* v = static_cast<std::vector<Setter>*>(out);
          const Setter s = reinterpret_cast<Setter>(f);
          if (std::find(v->begin(), v->end(), s) == v->end()) v->push_back(s);
        }
        dlclose(h);
        return 0;
      },
      &setters);
  for (Setter s : setters) s(onDeath);
  return !setters.empty();
}

void installHandlers() {
  const bool sanitized = registerDeathCallbacks();
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_handler = onSignal;
  sigaction(SIGABRT, &sa, nullptr);  // std::abort, std::terminate (sanitizers leave it alone)
  sigaction(SIGALRM, &sa, nullptr);  // --timeout-s
  if (!sanitized) {  // else the sanitizer reports these itself
    for (int s : {SIGSEGV, SIGBUS, SIGFPE, SIGILL}) sigaction(s, &sa, nullptr);
  }
}

// ---- files -------------------------------------------------------------------------------------
bool isDir(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

Bytes readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return Bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

/// The regular files of a folder (sorted, hidden files and READMEs skipped), or the file itself.
std::vector<std::string> listInputs(const std::string& path) {
  std::vector<std::string> out;
  if (!isDir(path)) {
    if (access(path.c_str(), R_OK) == 0) out.push_back(path);
    return out;
  }
  if (DIR* d = opendir(path.c_str())) {
    while (dirent* e = readdir(d)) {
      const std::string n = e->d_name;
      if (n.empty() || n[0] == '.' || n.rfind("README", 0) == 0) continue;
      const std::string p = path + "/" + n;
      if (!isDir(p)) out.push_back(p);
    }
    closedir(d);
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// libFuzzer dictionary files: lines `name="token"` or `"token"`, escapes \\ \" \xAB.
std::vector<Bytes> readDict(const std::string& path) {
  std::vector<Bytes> out;
  std::ifstream f(path);
  std::string line;
  while (std::getline(f, line)) {
    const size_t a = line.find('"'), b = line.rfind('"');
    if (line.empty() || line[0] == '#' || a == std::string::npos || b <= a) continue;
    Bytes t;
    for (size_t i = a + 1; i < b; ++i) {
      if (line[i] == '\\' && i + 1 < b) {
        if (line[i + 1] == 'x' && i + 3 < b) {
          t.push_back(static_cast<uint8_t>(std::stoi(line.substr(i + 2, 2), nullptr, 16)));
          i += 3;
        } else {
          t.push_back(static_cast<uint8_t>(line[++i]));
        }
      } else {
        t.push_back(static_cast<uint8_t>(line[i]));
      }
    }
    if (!t.empty()) out.push_back(t);
  }
  return out;
}

// ---- mutations ---------------------------------------------------------------------------------
class Mutator {
 public:
  Mutator(const std::vector<Bytes>& corpus, const std::vector<Bytes>& dict, size_t max_len)
      : corpus_(corpus), dict_(dict), max_len_(max_len) {}

  /// Mutated input `index` of stream `seed`: depends on (seed, index) and the corpus only.
  Bytes make(uint64_t seed, uint64_t index) {
    std::seed_seq seq{static_cast<uint32_t>(seed), static_cast<uint32_t>(seed >> 32),
                      static_cast<uint32_t>(index), static_cast<uint32_t>(index >> 32), 0x5eedu};
    rng_.seed(seq);
    Bytes b = corpus_[below(corpus_.size())];
    const int n = 1 + static_cast<int>(below(8));
    for (int k = 0; k < n; ++k) mutate(&b);
    if (b.size() > max_len_) b.resize(max_len_);
    return b;
  }

 private:
  uint64_t below(uint64_t n) { return n ? rng_() % n : 0; }
  size_t pos(const Bytes& b) { return below(b.size() + 1); }

  void writeAt(Bytes* b, const void* p, size_t n) {
    if (b->size() < n) b->resize(n);
    const size_t at = below(b->size() - n + 1);
    std::memcpy(b->data() + at, p, n);
  }

  void interestingInt(Bytes* b) {
    static const int64_t v[] = {0,          1,           -1,         2,          0x7f,
                                0x80,       0xff,        0x100,      0x7fff,     0x8000,
                                0xffff,     0x10000,     20000,      424,        512,
                                960,        0x7fffffff,  -0x80000000LL, 0xffffffffLL,
                                1000000000, 0x7fffffffffffffffLL};
    const int64_t x = v[below(sizeof v / sizeof v[0])];
    const size_t widths[] = {1, 2, 4, 8};
    const size_t w = widths[below(4)];
    writeAt(b, &x, w);  // little-endian: the low bytes
  }

  void interestingFloat(Bytes* b) {
    static const double v[] = {0.0,   -0.0, 1.0,  -1.0,   0.5,   1e-300, 1e300, 5e-324,
                               1e-45, 3e38, 1e9,  -1e9,   365.4, 5.0,    NAN,   INFINITY,
                               -INFINITY};
    const double x = v[below(sizeof v / sizeof v[0])];
    if (below(2)) {
      writeAt(b, &x, 8);
    } else {
      const float f = static_cast<float>(x);
      writeAt(b, &f, 4);
    }
  }

  /// A run of ASCII digits (with sign, dot, exponent) replaced by an edge-case number.
  void textNumber(Bytes* b) {
    static const char* const v[] = {"0",    "-0",   "1",     "-1",   "1e308", "-1e308", "1e-320",
                                    "nan",  ".nan", ".inf",  "-.inf", "inf",  "0x10",   "1e999",
                                    "2147483647", "2147483648", "4294967296", "-2147483649",
                                    "9223372036854775808", "99999999999999999999", "0.000001",
                                    "20000", "3.5", "1_000", "+5", "1e", "", "~", "null", "[]"};
    std::vector<size_t> starts;
    for (size_t i = 0; i < b->size(); ++i)
      if (isNumChar((*b)[i]) && (i == 0 || !isNumChar((*b)[i - 1]))) starts.push_back(i);
    const std::string r = v[below(sizeof v / sizeof v[0])];
    if (starts.empty()) {
      b->insert(b->begin() + pos(*b), r.begin(), r.end());
      return;
    }
    const size_t s = starts[below(starts.size())];
    size_t e = s;
    while (e < b->size() && isNumChar((*b)[e])) ++e;
    b->erase(b->begin() + s, b->begin() + e);
    b->insert(b->begin() + s, r.begin(), r.end());
  }
  static bool isNumChar(uint8_t c) {
    return (c >= '0' && c <= '9') || c == '.' || c == '-' || c == '+' || c == 'e' || c == 'E';
  }

  void mutate(Bytes* b) {
    switch (below(b->empty() ? 3 : 13)) {
      case 0: {  // insert random bytes
        Bytes r(1 + below(8));
        for (auto& x : r) x = static_cast<uint8_t>(rng_());
        b->insert(b->begin() + pos(*b), r.begin(), r.end());
        break;
      }
      case 1:  // a dictionary token (or an interesting int without a dictionary)
        if (dict_.empty()) {
          interestingInt(b);
        } else {
          const Bytes& t = dict_[below(dict_.size())];
          if (below(2) || b->size() < t.size())
            b->insert(b->begin() + pos(*b), t.begin(), t.end());
          else
            std::memcpy(b->data() + below(b->size() - t.size() + 1), t.data(), t.size());
        }
        break;
      case 2: {  // splice: a range of another corpus input, inserted or overwriting
        const Bytes& o = corpus_[below(corpus_.size())];
        if (o.empty()) break;
        const size_t a = below(o.size()), n = 1 + below(std::min<size_t>(o.size() - a, 256));
        if (below(2) || b->size() < n) {
          b->insert(b->begin() + pos(*b), o.begin() + a, o.begin() + a + n);
        } else {
          std::memcpy(b->data() + below(b->size() - n + 1), o.data() + a, n);
        }
        break;
      }
      case 3: {  // flip a bit
        (*b)[below(b->size())] ^= static_cast<uint8_t>(1u << below(8));
        break;
      }
      case 4:  // a random byte
        (*b)[below(b->size())] = static_cast<uint8_t>(rng_());
        break;
      case 5: {  // delete a range
        const size_t a = below(b->size());
        const size_t n = 1 + below(std::min<size_t>(b->size() - a, below(4) ? 8 : 256));
        b->erase(b->begin() + a, b->begin() + a + n);
        break;
      }
      case 6: {  // duplicate a range
        const size_t a = below(b->size()), n = 1 + below(std::min<size_t>(b->size() - a, 64));
        const Bytes r(b->begin() + a, b->begin() + a + n);
        b->insert(b->begin() + pos(*b), r.begin(), r.end());
        break;
      }
      case 7:
        interestingInt(b);
        break;
      case 8:
        interestingFloat(b);
        break;
      case 9:
        textNumber(b);
        break;
      case 10:  // truncate
        b->resize(below(b->size()));
        break;
      case 11: {  // add a small number to a byte
        uint8_t& x = (*b)[below(b->size())];
        x = static_cast<uint8_t>(x + static_cast<int>(below(33)) - 16);
        break;
      }
      default: {  // swap two bytes
        std::swap((*b)[below(b->size())], (*b)[below(b->size())]);
        break;
      }
    }
  }

  const std::vector<Bytes>& corpus_;
  const std::vector<Bytes>& dict_;
  size_t max_len_;
  std::mt19937_64 rng_;
};

// ---- running -----------------------------------------------------------------------------------
struct Stats {
  double seconds = 0, slowest = 0;
  std::string slowest_label;
};

long maxRssMb() {
  struct rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss / 1024;
}

/// Runs one input; false (after writing it to the artifact) on an exception or the RSS limit.
bool runOne(const Options& o, const Bytes& input, const std::string& label,
            const std::string& artifact, Stats* st, std::string* failure) {
  g_current = &input;
  std::snprintf(g_artifact, sizeof g_artifact, "%s", artifact.c_str());
  std::snprintf(g_label, sizeof g_label, "%s", label.c_str());
  if (o.timeout_s) alarm(o.timeout_s);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    LLVMFuzzerTestOneInput(input.data(), input.size());
  } catch (const std::exception& e) {
    *failure = "uncaught exception: " + std::string(e.what());
  } catch (...) {
    *failure = "uncaught exception of an unknown type";
  }
  const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (o.timeout_s) alarm(0);
  st->seconds += dt;
  if (dt > st->slowest) {
    st->slowest = dt;
    st->slowest_label = label;
  }
  if (failure->empty() && o.rss_limit_mb && static_cast<size_t>(maxRssMb()) > o.rss_limit_mb)
    *failure = "peak RSS " + std::to_string(maxRssMb()) + " MB exceeds --rss-limit-mb " +
               std::to_string(o.rss_limit_mb) + " (an input that allocates without bound?)";
  if (!failure->empty()) {
    dumpCurrent();
    std::fprintf(stderr, "[fuzz] %s: %s\n", label.c_str(), failure->c_str());
  }
  g_current = nullptr;
  return failure->empty();
}

std::string xmlEscape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else if (static_cast<unsigned char>(c) < 0x20 && c != '\n' && c != '\t') o += '?';
    else o += c;
  }
  return o;
}

void writeXml(const Options& o, const std::vector<std::pair<std::string, std::string>>& cases) {
  if (o.xml.empty()) return;
  std::ofstream f(o.xml);
  size_t failures = 0;
  for (const auto& c : cases) failures += !c.second.empty();
  f << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuite name=\"test_fuzz_" << kName
    << "\" tests=\"" << cases.size() << "\" failures=\"" << failures << "\" errors=\"0\">\n";
  for (const auto& c : cases) {
    f << "  <testcase classname=\"test_fuzz_" << kName << "\" name=\"" << c.first << "\"";
    if (c.second.empty())
      f << "/>\n";
    else
      f << "><failure message=\"" << xmlEscape(c.second) << "\"/></testcase>\n";
  }
  f << "</testsuite>\n";
}

[[noreturn]] void usage(int rc) {
  std::fprintf(rc ? stderr : stdout,
               "usage: test_fuzz_%s [--runs N] [--seed S] [--only I] [--max-len BYTES] "
               "[--artifacts DIR] [--dict FILE] [--timeout-s T] [--rss-limit-mb M] [--xml FILE] "
               "[--quiet] [--regressions DIR]... [--corpus DIR]... [FILE_OR_DIR]...\n"
               "Replays test/fuzz/regressions/%s and test/fuzz/corpus/%s (unless folders are "
               "given), then N mutated inputs (default 10000) from seed S (default 1).\n",
               kName, kName, kName);
  std::exit(rc);
}

uint64_t number(const char* opt, const char* v) {
  char* end = nullptr;
  errno = 0;
  const unsigned long long x = std::strtoull(v, &end, 10);
  if (!*v || *end || errno || v[0] == '-') {
    std::fprintf(stderr, "test_fuzz_%s: %s needs a non-negative integer, got '%s'\n", kName, opt,
                 v);
    std::exit(2);
  }
  return x;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto val = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "test_fuzz_%s: %s needs a value\n", kName, a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "-h" || a == "--help") usage(0);
    else if (a == "--runs") o.runs = number("--runs", val());
    else if (a == "--seed") o.seed = number("--seed", val());
    else if (a == "--only") o.only = static_cast<int64_t>(number("--only", val()));
    else if (a == "--max-len") o.max_len = number("--max-len", val());
    else if (a == "--artifacts") o.artifacts = val();
    else if (a == "--dict") o.dicts.push_back(val());
    else if (a == "--timeout-s") o.timeout_s = static_cast<unsigned>(number("--timeout-s", val()));
    else if (a == "--rss-limit-mb") o.rss_limit_mb = number("--rss-limit-mb", val());
    else if (a == "--xml") o.xml = val();
    else if (a == "--quiet") o.quiet = true;
    else if (a == "--regressions") o.regressions.push_back(val()), o.default_dirs = false;
    else if (a == "--corpus") o.corpus.push_back(val()), o.default_dirs = false;
    else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "test_fuzz_%s: unknown option %s\n", kName, a.c_str());
      usage(2);
    } else {
      o.corpus.push_back(a);
      o.default_dirs = false;
    }
  }
  const std::string dir = DPP_FUZZ_DIR;
  if (o.default_dirs) {
    o.regressions.push_back(dir + "/regressions/" + kName);
    o.corpus.push_back(dir + "/corpus/" + kName);
  }
  if (o.dicts.empty() && access((dir + "/dict/" + kName + ".dict").c_str(), R_OK) == 0)
    o.dicts.push_back(dir + "/dict/" + kName + ".dict");
  return o;
}

std::string baseName(const std::string& p) {
  const size_t s = p.rfind('/');
  return s == std::string::npos ? p : p.substr(s + 1);
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  installHandlers();
  mkdir(o.artifacts.c_str(), 0755);
  std::vector<std::pair<std::string, std::string>> cases;  // (test case, failure)
  Stats st;
  const auto t_start = std::chrono::steady_clock::now();

  // 1. Regressions, 2. the seed corpus: replayed as they are.
  std::vector<Bytes> corpus;
  size_t n_regressions = 0;
  for (int pass = 0; pass < 2; ++pass) {
    for (const std::string& d : pass == 0 ? o.regressions : o.corpus) {
      for (const std::string& f : listInputs(d)) {
        const Bytes input = readFile(f);
        corpus.push_back(input);  // regressions are good starting points for mutation too
        n_regressions += pass == 0;
        if (o.only >= 0) continue;
        std::string failure;
        const std::string label = (pass == 0 ? "regression " : "corpus input ") + f;
        if (!runOne(o, input, label, o.artifacts + "/crash-" + kName + "-" + baseName(f), &st,
                    &failure)) {
          cases.emplace_back(pass == 0 ? "regressions" : "corpus", label + ": " + failure);
          writeXml(o, cases);
          return 1;
        }
      }
    }
  }
  if (o.only < 0) {
    cases.emplace_back("regressions", "");
    cases.emplace_back("corpus", "");
  }
  if (corpus.empty()) {
    std::fprintf(stderr, "test_fuzz_%s: no corpus input (folders: %s ...)\n", kName,
                 o.corpus.empty() ? "none" : o.corpus[0].c_str());
    return 2;
  }
  std::vector<Bytes> dict;
  for (const std::string& d : o.dicts) {
    const std::vector<Bytes> t = readDict(d);
    dict.insert(dict.end(), t.begin(), t.end());
  }
  size_t max_len = o.max_len;
  if (!max_len) {
    for (const Bytes& b : corpus) max_len = std::max(max_len, 2 * b.size());
    max_len = std::max<size_t>(max_len, 4096);
  }
  if (!o.quiet)
    std::printf("test_fuzz_%s: seed %llu, %llu mutated inputs from %zu corpus inputs "
                "(%zu regressions), %zu dictionary tokens, max length %zu\n",
                kName, static_cast<unsigned long long>(o.seed),
                static_cast<unsigned long long>(o.only >= 0 ? 1 : o.runs), corpus.size(),
                n_regressions, dict.size(), max_len);
  std::fflush(stdout);

  // 3. Mutated inputs.
  Mutator mut(corpus, dict, max_len);
  const uint64_t first = o.only >= 0 ? static_cast<uint64_t>(o.only) : 0;
  const uint64_t end = o.only >= 0 ? first + 1 : o.runs;
  uint64_t next_report = 1;
  for (uint64_t i = first; i < end; ++i) {
    const Bytes input = mut.make(o.seed, i);
    const std::string label = "seed " + std::to_string(o.seed) + " input " + std::to_string(i) +
                              " (reproduce: test_fuzz_" + kName + " --seed " +
                              std::to_string(o.seed) + " --only " + std::to_string(i) + ")";
    const std::string artifact = o.artifacts + "/crash-" + kName + "-seed" +
                                 std::to_string(o.seed) + "-input" + std::to_string(i);
    std::string failure;
    if (!runOne(o, input, label, artifact, &st, &failure)) {
      cases.emplace_back("mutations", label + ": " + failure);
      writeXml(o, cases);
      return 1;
    }
    if (!o.quiet && i + 1 >= next_report) {
      const double el =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
      std::printf("test_fuzz_%s: %llu inputs, %.1f s, %.0f inputs/s\n", kName,
                  static_cast<unsigned long long>(i + 1), el, (i + 1) / std::max(el, 1e-9));
      std::fflush(stdout);
      next_report *= 10;
    }
  }
  if (o.runs || o.only >= 0) cases.emplace_back("mutations", "");
  const double total =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  std::printf("test_fuzz_%s: PASSED %zu replayed + %llu mutated inputs (seed %llu) in %.1f s; "
              "slowest %.3f s (%s); peak RSS %ld MB\n",
              kName, o.only >= 0 ? size_t{0} : corpus.size(),
              static_cast<unsigned long long>(end - first), static_cast<unsigned long long>(o.seed),
              total, st.slowest, st.slowest_label.c_str(), maxRssMb());
  writeXml(o, cases);
  return 0;
}
