! The tube's wall as a preCICE v3 participant in Fortran (preCICE's precicef_* subroutines), built against cosim's
! libprecice (or preCICE itself): the same quasi-static wall as solid_component/tube.py, in the same arithmetic.
!
!   cmake -S . -B build && cmake --build build      (find_package(precice 3 CONFIG): `cosim libprecice env`)
!   ./build/SolidSolver ../precice-config.xml
program SolidSolver
  implicit none
  integer, parameter :: dp = kind(1.0d0), cells = 100, n = cells + 1
  real(dp), parameter :: length = 10.0_dp, a0 = 1.0_dp, e_small = 12500.0_dp, e_large = 2500.0_dp, &
                         s0 = 20.0_dp, eps0 = 2e-3_dp, pi = 3.141592653589793_dp
  character(len=512) :: config
  real(dp) :: coordinates(2 * n), pressure(n), section(n), dt
  integer :: ids(n), i, ongoing, initial, required

  if (command_argument_count() < 1) then
    write (0, '(a)') 'usage: SolidSolver PRECICE-CONFIG'
    stop 2
  end if
  call get_command_argument(1, config)
  do i = 1, n
    coordinates(2 * i - 1) = (i - 1) * (length / cells)
    coordinates(2 * i) = 0.0_dp
    section(i) = a0
  end do
  coordinates(2 * n - 1) = length

  call precicef_create('Solid', trim(config), 0, 1)
  call precicef_set_vertices('Solid-Nodes', n, coordinates, ids)
  call precicef_requires_initial_data(initial)
  if (initial == 1) call precicef_write_data('Solid-Nodes', 'CrossSectionLength', n, ids, section)
  call precicef_initialize()
  call precicef_is_coupling_ongoing(ongoing)
  do while (ongoing == 1)
    call precicef_requires_writing_checkpoint(required)   ! quasi-static: no state to save
    call precicef_get_max_time_step_size(dt)
    call precicef_read_data('Solid-Nodes', 'Pressure', n, ids, dt, pressure)
    do i = 1, n
      section(i) = section_of(pressure(i))
    end do
    call precicef_write_data('Solid-Nodes', 'CrossSectionLength', n, ids, section)
    call precicef_advance(dt)
    call precicef_requires_reading_checkpoint(required)
    call precicef_is_coupling_ongoing(ongoing)
  end do
  call precicef_finalize()

contains

  ! hoop equilibrium p r = sigma((r - r0) / r0): the piecewise-linear law's exact root, as a section
  real(dp) function section_of(p)
    real(dp), intent(in) :: p
    real(dp) :: r0, pr0, r_small, r_up, r_down, eps_small, r
    r0 = sqrt(a0 / pi)
    pr0 = p * r0
    r_small = r0 * e_small / (e_small - pr0)
    r_up = r0 * (e_large - s0) / (e_large - pr0)
    r_down = r0 * (e_large + s0) / (e_large - pr0)
    eps_small = r_small / r0 - 1.0_dp
    if (abs(eps_small) < eps0) then
      r = r_small
    else if (eps_small > 0) then
      r = r_up
    else
      r = r_down
    end if
    section_of = pi * (r * r)
  end function section_of

end program SolidSolver
