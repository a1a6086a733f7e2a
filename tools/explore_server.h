/*
 * tools/explore_server.h: `specula explore SCENE.xml [--port N]`, the solver explorer's HTTP
 * server (explore_server.c), called by tools/specula.c. Returns the process exit code.
 */
#ifndef SPC_TOOLS_EXPLORE_SERVER_H
#define SPC_TOOLS_EXPLORE_SERVER_H

int spc_cli_explore(int argc, char **argv);

#endif
