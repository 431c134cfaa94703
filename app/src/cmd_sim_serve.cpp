// paintlab sim serve --rig R: the simulated rig's peers for other processes. Prints one line
// per endpoint as soon as it is ready, then serves until SIGINT or SIGTERM:
//   modbus-tcp 127.0.0.1:PORT
//   modbus-rtu /dev/pts/N
//   gige 127.0.0.1
#include <csignal>
#include <fmt/format.h>
#include <pthread.h>

#include "rig_devices.h"
#include "cli.h"
#include "paintlab/core/log.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/peers/sim_rig.h"

namespace paintlab::app {

void register_sim_serve_command(CLI::App& app) {
  CLI::App* sim = subcommand_group(app, "sim", "The simulated rig");
  struct Args {
    std::string rig;
    int port = 1502;
    bool no_rtu = false;
    bool no_camera = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* serve = sim->add_subcommand(
      "serve",
      "Serve the simulated rig's devices on 127.0.0.1 for other processes: the turntable as Modbus TCP (and RTU on "
      "a pty pair), the camera as GigE Vision; the LED stays on. Prints one line per endpoint, runs until "
      "SIGINT/SIGTERM.");
  serve->add_option("--rig", args->rig, "rig.toml of the simulated rig")->required();
  serve->add_option("--modbus-port", args->port, "TCP port of the Modbus server (0: any free port)")
      ->check(CLI::Range(0, 65535));
  serve->add_flag("--no-rtu", args->no_rtu, "Do not serve Modbus RTU on a pty pair (needs socat)");
  serve->add_flag("--no-camera", args->no_camera, "Do not serve the GigE Vision camera (port 3956)");
  on_run(serve, [args] {
    RigConfig rig = load_rig(args->rig);
    // Block the signals in every thread the peers start; this thread waits for them.
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    sim::SimRigOptions o;
    o.modbus_port = args->port;
    o.modbus_rtu = !args->no_rtu;
    o.camera = !args->no_camera;
    o.light = false;
    // Other processes cannot wait on a virtual clock: the peers run on the wall clock.
    o.clock = &system_clock();
    sim::SimRig peers(rig, o);
    peers.world().set_led_on(true);
    say(fmt::format("modbus-tcp 127.0.0.1:{}", peers.modbus_port()));
    if (!peers.modbus_rtu_path().empty()) say("modbus-rtu " + peers.modbus_rtu_path());
    if (peers.camera()) say("gige 127.0.0.1");
    int sig = 0;
    sigwait(&set, &sig);
    spdlog::info("sim serve: {} received, stopping", sig == SIGINT ? "SIGINT" : "SIGTERM");
    return 0;
  });
}

}  // namespace paintlab::app
