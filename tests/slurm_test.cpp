// The Slurm job array (scripts/slurm_sweep.sh) on a private single-node Slurm started here:
// Debian's slurm-wlm and munge, loopback only, its own munge key, socket, ports and state in a
// temporary folder; a 2-task array of the tiny sweep, then `minv merge`, and the merged points
// must equal a one-process run's (identity attributes and parent arrays). Where Slurm cannot
// start (not installed, not root, a daemon fails) the test is skipped with the reason printed.
// Everything it starts is stopped by pid at the end. Capped at about 3 minutes.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "experiments/lib/h5reader.hpp"
#include "experiments/lib/timing.hpp"
#include "tests/test_util.hpp"

namespace fs = std::filesystem;
using minv::test::shell;
using minv::test::slurp;
using minv::test::tempDir;

namespace {

int freePort() {
  const int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  getsockname(s, reinterpret_cast<sockaddr*>(&a), &len);
  const int port = ntohs(a.sin_port);
  close(s);
  return port;
}

// Starts munged, slurmctld and slurmd for one node; exit 0 when the node is idle, else 3 with
// the reason in $D/reason.
const char* kStart = R"SH(#!/usr/bin/env bash
D=$1; CTLD_PORT=$2; SLURMD_PORT=$3
fail() { echo "$*" > "$D/reason"; exit 3; }
for b in munged slurmctld slurmd sbatch sinfo; do
  command -v $b >/dev/null || [ -x /usr/sbin/$b ] || fail "$b not installed (Debian packages slurm-wlm and munge)"
done
PATH=$PATH:/usr/sbin
[ "$(id -u)" = 0 ] || fail "needs root to run slurmd"
H=$(hostname -s)
dd if=/dev/urandom bs=1 count=1024 of="$D/munge.key" 2>/dev/null; chmod 600 "$D/munge.key"
munged --force --socket="$D/munge.socket" --key-file="$D/munge.key" --pid-file="$D/munged.pid" \
  --log-file="$D/munged.log" --seed-file="$D/munge.seed" || fail "munged did not start: $(tail -2 $D/munged.log 2>/dev/null)"
mkdir -p "$D/state" "$D/spool"
cat > "$D/slurm.conf" <<EOF
ClusterName=minvtest
SlurmctldHost=$H(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
AuthType=auth/munge
AuthInfo=socket=$D/munge.socket
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$D/state
SlurmdSpoolDir=$D/spool
SlurmctldPidFile=$D/slurmctld.pid
SlurmdPidFile=$D/slurmd.pid
SlurmctldLogFile=$D/slurmctld.log
SlurmdLogFile=$D/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
NodeName=$H NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=minvtest Nodes=$H Default=YES MaxTime=10 State=UP
EOF
export SLURM_CONF="$D/slurm.conf"
slurmctld -i || fail "slurmctld did not start: $(tail -2 $D/slurmctld.log 2>/dev/null)"
slurmd || fail "slurmd did not start: $(tail -2 $D/slurmd.log 2>/dev/null)"
for i in $(seq 60); do
  sinfo -h -o %t 2>/dev/null | grep -q idle && exit 0
  sleep 1
done
fail "the node did not become idle in 60 s: $(tail -2 $D/slurmctld.log) $(tail -2 $D/slurmd.log)"
)SH";

struct Cluster {
  fs::path dir;
  ~Cluster() {
    for (const char* d : {"slurmd", "slurmctld", "munged"}) {
      const fs::path pid = dir / (std::string(d) + ".pid");
      if (fs::exists(pid)) shell("kill $(cat " + pid.string() + ") 2>/dev/null");
    }
    shell("sleep 1");
    fs::remove_all(dir);
  }
};

}  // namespace

TEST(Slurm, JobArrayShardsMergeToTheOneProcessRun) {
  const fs::path bin_dir = fs::path(MINV_CLI).parent_path();
  ASSERT_TRUE(fs::exists(bin_dir / "bench_timing")) << "build the bench_timing target";
  Cluster c;
  c.dir = fs::temp_directory_path() / ("minv_slurm_" + std::to_string(getpid()));
  fs::create_directories(c.dir);
  fs::permissions(c.dir, fs::perms::owner_all);
  { std::ofstream(c.dir / "start.sh") << kStart; }
  const int rc = shell("bash " + (c.dir / "start.sh").string() + " " + c.dir.string() + " " +
                       std::to_string(freePort()) + " " + std::to_string(freePort()) + " > " +
                       (c.dir / "start.log").string() + " 2>&1");
  if (rc != 0) {
    std::string why = slurp(c.dir / "reason");
    if (why.empty()) why = "start script failed: " + slurp(c.dir / "start.log");
    std::printf("Slurm test skipped: %s\n", why.c_str());
    GTEST_SKIP() << why;
  }
  const std::string env =
      "SLURM_CONF=" + (c.dir / "slurm.conf").string() + " PATH=$PATH:/usr/sbin ";
  const fs::path out = c.dir / "out";
  const std::string script = fs::path(MINV_SOURCE_DIR) / "scripts" / "slurm_sweep.sh";
  const int sb =
      shell("cd " + std::string(MINV_SOURCE_DIR) + " && " + env +
            "timeout 150 sbatch --wait --array=0-1 -o " + (c.dir / "task_%a.out").string() + " " +
            script + " --mode tiny --build " + bin_dir.string() + " --out-dir " + out.string() +
            " > " + (c.dir / "sbatch.log").string() + " 2>&1");
  ASSERT_EQ(sb, 0) << slurp(c.dir / "sbatch.log") << slurp(c.dir / "task_0.out")
                   << slurp(c.dir / "task_1.out") << slurp(c.dir / "slurmd.log");
  const fs::path s0 = out / "shards" / "timing.0of2.h5", s1 = out / "shards" / "timing.1of2.h5";
  ASSERT_TRUE(fs::exists(s0) && fs::exists(s1)) << slurp(c.dir / "task_0.out");
  ASSERT_EQ(shell(std::string(MINV_CLI) + " merge --out " + (out / "timing.h5").string() + " " +
                  s0.string() + " " + s1.string() + " > /dev/null"),
            0);
  ASSERT_EQ(shell((bin_dir / "bench_timing").string() + " --mode tiny --min-time 0.001 --out " +
                  (c.dir / "one.h5").string() + " > /dev/null"),
            0);
  const auto merged = minv::readPoints((out / "timing.h5").string());
  const auto one = minv::readPoints((c.dir / "one.h5").string());
  ASSERT_EQ(merged.size(), one.size());
  for (const auto& [name, rec] : one) {
    ASSERT_TRUE(merged.count(name)) << name;
    for (const char* key :
         {"family", "solver", "topology", "base", "n", "nv", "m", "threads", "seed", "status"})
      EXPECT_EQ(merged.at(name).attrs.at(key), rec.attrs.at(key)) << name << " " << key;
    EXPECT_EQ(merged.at(name).parent, rec.parent) << name;
  }
}
