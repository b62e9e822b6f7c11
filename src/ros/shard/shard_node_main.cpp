// A fusion shard as a plain node (the same class the nodelet wraps).
#include "src/ros/common/node_runner.h"
#include "src/ros/shard/shard_node.h"

int main(int argc, char** argv) {
  return bsf_vpr::RunNode<bsf_vpr::ShardNode>(argc, argv, "shard");
}
