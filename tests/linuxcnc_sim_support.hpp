#pragma once
// The headless LinuxCNC simulator for tests (linuxcnc-uspace): XYZAC, trivkins, simulated homing,
// linuxcncrsh as the display, optionally a simulated touch probe. One simulator on the machine at a
// time: a test holds MachineLock (/tmp/alc_linuxcnc_sim.flock) and its CTest tests RESOURCE_LOCK linuxcnc.
//
// The simulated probe (with_probe): a HAL `comp` in the servo thread sets motion.probe-input when joint
// 2 (Z) is below probe_z.in1, the "surface" [mm, machine Z]; Simulator::set_surface moves it (halcmd setp).
#include <catch2/catch.hpp>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>

#include "nc_interface/nc_test_support.hpp"
#include "nc_interface/transports.hpp"

namespace alc::nc::test {

inline std::string sim_ini(int port, bool with_probe) {
  std::ostringstream s;
  s << "[EMC]\nVERSION = 1.1\nMACHINE = ALC-NC-TEST\nDEBUG = 0\n"
    << "[DISPLAY]\nDISPLAY = linuxcncrsh -p " << port << "\n"
    << "[TASK]\nTASK = milltask\nCYCLE_TIME = 0.010\n"
    << "[RS274NGC]\nPARAMETER_FILE = sim.var\n"
    << "[EMCMOT]\nEMCMOT = motmod\nCOMM_TIMEOUT = 1.0\nSERVO_PERIOD = 1000000\n"
    << "[EMCIO]\nEMCIO = io\nCYCLE_TIME = 0.100\nTOOL_TABLE = sim.tbl\n"
    << "[HAL]\nHALFILE = LIB:basic_sim.tcl -no_use_hal_manualtoolchange\n"
    << (with_probe ? "HALFILE = probe.hal\n" : "")
    << "[TRAJ]\nCOORDINATES = X Y Z A C\nLINEAR_UNITS = mm\nANGULAR_UNITS = degree\nMAX_LINEAR_VELOCITY = 50\n"
    << "[KINS]\nKINEMATICS = trivkins coordinates=XYZAC\nJOINTS = 5\n";
  const char* axes = "XYZAC";
  for (int j = 0; j < 5; ++j) {
    const bool linear = j < 3;
    const int lim = linear ? 500 : 3600;
    s << "[AXIS_" << axes[j] << "]\nMAX_VELOCITY = 50\nMAX_ACCELERATION = 500\nMIN_LIMIT = -" << lim
      << "\nMAX_LIMIT = " << lim << "\n"
      << "[JOINT_" << j << "]\nTYPE = " << (linear ? "LINEAR" : "ANGULAR")
      << "\nHOME = 0\nMAX_VELOCITY = 50\nMAX_ACCELERATION = 500\nMIN_LIMIT = -" << lim << "\nMAX_LIMIT = " << lim
      << "\nFERROR = 10\nMIN_FERROR = 1\nHOME_OFFSET = 0\nHOME_SEARCH_VEL = 0\nHOME_LATCH_VEL = 0\nHOME_SEQUENCE = 0\n";
  }
  return s.str();
}

// Runs `linuxcnc -r sim.ini` in its own process group; stops it by its PID (never by name).
class Simulator {
 public:
  // with_probe: the simulated probe, its surface at `surface_mm` (machine Z) to begin with.
  Simulator(std::filesystem::path dir, int port, bool with_probe = false, double surface_mm = -1000.0)
      : dir_(std::move(dir)), port_(port) {
    write_text(dir_ / "sim.ini", sim_ini(port, with_probe));
    write_text(dir_ / "sim.var", "3001 0.0\n");
    write_text(dir_ / "sim.tbl", "T1 P1 Z0 D0 ;\n");
    if (with_probe)
      write_text(dir_ / "probe.hal", "loadrt comp names=probe_z\naddf probe_z servo-thread\n"
                                     "net probe-z-pos joint.2.pos-fb => probe_z.in0\nsetp probe_z.in1 " +
                                         std::to_string(surface_mm) + "\nnet probe-trip probe_z.out => motion.probe-input\n");
    const auto fifo_dir = dir_ / "rtapi";
    std::filesystem::create_directories(fifo_dir);
    const bool root = ::geteuid() == 0;
    // As root, rtapi_app drops to RTAPI_UID and needs its socket in a directory that user owns.
    if (root && ::chown(fifo_dir.c_str(), 65534, 65534) != 0) FAIL("cannot chown " << fifo_dir << " to nobody");
    if (root) std::filesystem::permissions(dir_, std::filesystem::perms::all, std::filesystem::perm_options::add);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::setsid();
      if (::chdir(dir_.c_str()) != 0) ::_exit(126);
      const int log = ::open("run.log", O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(log, 1);
      ::dup2(log, 2);
      ::unsetenv("DISPLAY");
      set_rtapi_env();
      ::execlp("linuxcnc", "linuxcnc", "-r", "sim.ini", static_cast<char*>(nullptr));
      ::_exit(127);
    }
  }
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  int port() const { return port_; }

  bool running() {
    if (pid_ <= 0) return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return false;
    }
    return true;
  }

  std::string log() const { return read_text(dir_ / "run.log"); }

  // Waits (at most 90 s) until linuxcncrsh listens; then estop off, machine on, all joints homed,
  // and the session closed (linuxcncrsh gives control to one session at a time).
  void wait_ready(const LinuxcncrshOptions& options) {
    LinuxcncrshClient client(options);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(90);
    while (!client.connected()) {
      if (!running()) FAIL("linuxcnc exited before linuxcncrsh listened; its log:\n" << log());
      if (std::chrono::steady_clock::now() > deadline) {
        stop(nullptr);
        FAIL("linuxcncrsh did not listen on port " << port_ << " within 90 s; log:\n" << log());
      }
      try {
        client.connect();
      } catch (const SinkError&) {
        std::this_thread::sleep_for(std::chrono::milliseconds(500));
      }
    }
    client.set("estop off");
    client.set("machine on");
    client.set("home -1");
    for (int i = 0; i < 100 && client.request("get joint_homed").rfind("JOINT_HOMED YES YES YES YES YES", 0) != 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    client.close();
  }

  // Moves the simulated probe's surface to `z_mm` (machine Z) with halcmd; true when halcmd succeeded.
  bool set_surface(double z_mm) {
    const pid_t pid = ::fork();
    if (pid == 0) {
      if (::chdir(dir_.c_str()) != 0) ::_exit(126);
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, 1);
      set_rtapi_env();
      char value[64];
      std::snprintf(value, sizeof value, "%.6f", z_mm);
      ::execlp("halcmd", "halcmd", "setp", "probe_z.in1", value, static_cast<char*>(nullptr));
      ::_exit(127);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) && WEXITSTATUS(status) == 0;
  }

  // Stops by asking linuxcncrsh to shut down (over `client`, a session of the caller's), then by
  // signals to the process group; bounded.
  void stop(LinuxcncrshClient* client) {
    bool asked = false;
    if (client && client->connected()) {
      try {
        client->request("shutdown");
        asked = true;
      } catch (const std::exception&) {
      }
    }
    for (int sig : {0, SIGTERM, SIGKILL}) {
      if (sig == 0 && !asked) continue;
      if (sig != 0 && pid_ > 0) ::kill(-pid_, sig);
      for (int i = 0; i < 300 && running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      if (!running()) return;
    }
  }

  ~Simulator() { stop(nullptr); }

 private:
  void set_rtapi_env() const {
    if (::geteuid() != 0) return;
    ::setenv("RTAPI_UID", "65534", 1);
    ::setenv("RTAPI_FIFO_PATH", (dir_ / "rtapi" / "rtapi_fifo").c_str(), 1);
  }
  std::filesystem::path dir_;
  int port_;
  pid_t pid_ = -1;
};

// One simulator on the machine at a time (LinuxCNC allows one instance, /tmp/linuxcnc.lock).
class MachineLock {
 public:
  MachineLock() {
    fd_ = ::open("/tmp/alc_linuxcnc_sim.flock", O_RDWR | O_CREAT, 0666);
    for (int i = 0; i < 1800 && fd_ >= 0; ++i) {
      if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    FAIL("another LinuxCNC simulator test held /tmp/alc_linuxcnc_sim.flock for 3 minutes");
  }
  ~MachineLock() {
    if (fd_ >= 0) ::close(fd_);
  }
  MachineLock(const MachineLock&) = delete;
  MachineLock& operator=(const MachineLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace alc::nc::test
