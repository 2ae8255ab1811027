! The tube's Solid in Fortran that reads data it does not read, naming a mesh padded with blanks as Fortran strings
! are: the program ends with one line naming the call, exit code 2.
program misuse
  implicit none
  character(len=512) :: config
  character(len=40) :: mesh = 'Solid-Nodes'
  double precision :: coordinates(2) = (/0.0d0, 0.0d0/), values(1), section(1) = (/1.0d0/)
  integer :: id
  call get_command_argument(1, config)
  call precicef_create('Solid', trim(config), 0, 1)
  call precicef_set_vertex(mesh, coordinates, id)
  call precicef_write_data(mesh, 'CrossSectionLength', 1, id, section)
  call precicef_initialize()
  call precicef_read_data(mesh, 'Section', 1, id, 0.0d0, values)
end program misuse
