/* The tube's Solid in C that misuses the C API as it is told (argv[2]): a call before the participant exists, or
 * data written on a mesh it does not have. Each ends the program with its line and exit code 2. */
#include <string.h>

#include <precice/preciceC.h>

int main(int argc, char **argv)
{
  double coordinates[2] = {0.0, 0.0}, value = 1.0;
  int    id;
  if (argc > 2 && strcmp(argv[2], "before-create") == 0) precicec_initialize();
  precicec_createParticipant("Solid", argv[1], 0, 1);
  id = precicec_setMeshVertex("Solid-Nodes", coordinates);
  precicec_writeData("Solid-Mesh", "CrossSectionLength", 1, &id, &value);
  return 0;
}
