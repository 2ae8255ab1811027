! A tour of preCICE's Fortran API through cosim's libprecice: tour.cpp's parts (the second argument), the same calls
! in Fortran (the older names, precicef_set_vertex and its kind, in some parts), against the same partners and
! configuration (the first argument); what the participant reads goes to seen.txt, a failed check stops it with
! exit code 3.
program tour
  implicit none
  character(len=512) :: config, part, name
  character(len=80) :: version
  integer :: communicator = 0
  call get_command_argument(1, config)
  call get_command_argument(2, part)
  call get_command_argument(3, name)
  call precicef_get_version_information(version)
  print '(a, a)', 'preCICE ', trim(version)
  open(10, file='seen.txt', status='replace', action='write')
  if (trim(part) == 'gradient') then
    call precicef_create_with_communicator(trim(name), trim(config), 0, 1, communicator)
  else
    call precicef_create(trim(name), trim(config), 0, 1)
  end if
  select case (trim(part))
  case ('subcycling')
    call subcycling()
  case ('partner')
    call partner()
  case ('direct')
    call direct()
  case ('jit')
    call jit()
  case ('gradient')
    call gradient()
  case ('reset')
    call reset()
  case default
    call field(trim(part))
  end select
  call precicef_finalize()
  close(10)

contains

  subroutine check(holds, what)
    logical, intent(in) :: holds
    character(len=*), intent(in) :: what
    if (.not. holds) then
      write(0, '(a, a)') 'tour: check failed: ', what
      call exit(3)
    end if
  end subroutine check

  subroutine record(values)
    double precision, intent(in) :: values(:)
    integer :: i
    do i = 1, size(values)
      if (i > 1) write(10, '(a)', advance='no') ' '
      write(10, '(es25.17e3)', advance='no') values(i)
    end do
    write(10, '(a)') ''
  end subroutine record

  subroutine subcycling()
    double precision :: first(2) = (/0.0d0, 0.0d0/), second(2) = (/1.0d0, 0.0d0/), x(2) = (/1.0d0, 2.0d0/)
    double precision :: saved(2), b(2), dt
    integer :: ids(2), dimensions, components, connectivity, vertices, initial, ongoing, writing, reading
    integer :: complete, step
    call precicef_get_mesh_dimensions('A-Mesh', dimensions)
    call precicef_get_data_dimensions('A-Mesh', 'X', components)
    call check(dimensions == 2 .and. components == 1, 'dimensions')
    call precicef_requires_mesh_connectivity_for('A-Mesh', connectivity)
    call check(connectivity == 0, 'no connectivity asked')
    call precicef_set_mesh_vertex('A-Mesh', first, ids(1))
    call precicef_set_mesh_vertices('A-Mesh', 1, second, ids(2))
    call precicef_get_mesh_vertex_size('A-Mesh', vertices)
    call check(ids(1) == 0 .and. ids(2) == 1 .and. vertices == 2, 'vertex ids')
    call precicef_requires_initial_data(initial)
    call check(initial == 0, 'no initial data')
    call precicef_initialize()
    call precicef_is_coupling_ongoing(ongoing)
    do while (ongoing /= 0)
      call precicef_requires_writing_checkpoint(writing)
      if (writing /= 0) saved = x
      do step = 0, 3
        call precicef_start_profiling_section('step')
        call precicef_get_max_time_step_size(dt)
        dt = dt / (4 - step)
        call precicef_read_data('A-Mesh', 'B', 2, ids, dt, b)
        call record(b)
        x = x + dt * (b - x)
        call precicef_write_data('A-Mesh', 'X', 2, ids, x)
        call precicef_stop_last_profiling_section()
        call precicef_advance(dt)
        call precicef_is_time_window_complete(complete)
        call check(step == 3 .or. complete == 0, 'a step inside the window completes none')
      end do
      call precicef_requires_reading_checkpoint(reading)
      call check((complete /= 0) .neqv. (reading /= 0), 'the window completes unless it is repeated')
      if (reading /= 0) x = saved
      call precicef_is_coupling_ongoing(ongoing)
    end do
  end subroutine subcycling

  subroutine partner()
    double precision :: grid(2, 2), x(2), b(2), t = 0.0d0, dt
    integer :: ids(2), ongoing, reading, writing
    grid = reshape((/0.0d0, 0.0d0, 1.0d0, 0.0d0/), (/2, 2/))
    call precicef_set_mesh_vertices('B-Mesh', 2, grid, ids)
    call precicef_initialize()
    call precicef_is_coupling_ongoing(ongoing)
    do while (ongoing /= 0)
      call precicef_requires_writing_checkpoint(writing)   ! asked, as preCICE wants (no state to save)
      call precicef_get_max_time_step_size(dt)
      call precicef_read_data('B-Mesh', 'X', 2, ids, dt, x)
      b = 0.5d0 * x + sin(t + dt)
      call precicef_write_data('B-Mesh', 'B', 2, ids, b)
      call precicef_advance(dt)
      call precicef_requires_reading_checkpoint(reading)
      if (reading == 0) t = t + dt
      call precicef_is_coupling_ongoing(ongoing)
    end do
  end subroutine partner

  subroutine direct()
    double precision :: origin(2) = (/0.0d0, 0.0d0/), box(4) = (/0.25d0, 0.75d0, -1.0d0, 1.0d0/), t = 0.0d0, dt
    double precision, allocatable :: coordinates(:, :), values(:)
    integer, allocatable :: ids(:)
    integer :: id, vertices, ongoing
    call precicef_set_vertex('Accessor-Mesh', origin, id)
    call precicef_set_mesh_access_region('Provider-Mesh', box)
    call precicef_initialize()
    call precicef_get_mesh_vertex_size('Provider-Mesh', vertices)
    allocate(ids(vertices), coordinates(2, vertices), values(vertices))
    call precicef_get_mesh_vertex_ids_and_coordinates('Provider-Mesh', vertices, ids, coordinates)
    call record(dble(ids))
    call record(reshape(coordinates, (/2 * vertices/)))
    call precicef_is_coupling_ongoing(ongoing)
    do while (ongoing /= 0)
      call precicef_get_max_time_step_size(dt)
      t = t + dt
      values = t + coordinates(1, :) * coordinates(1, :)
      call precicef_write_data('Provider-Mesh', 'D', vertices, ids, values)
      call precicef_advance(dt)
      call precicef_is_coupling_ongoing(ongoing)
    end do
  end subroutine direct

  subroutine jit()
    double precision :: box(4) = (/-1.0d0, 2.0d0, -1.0d0, 1.0d0/), forces(3) = (/1.0d0, 2.0d0, 3.0d0/)
    double precision :: points(2, 3), values(3), single(1) = (/5.0d0/), dt
    integer :: ongoing
    points = reshape((/0.12d0, 0.0d0, 0.5d0, 0.1d0, 0.93d0, 0.0d0/), (/2, 3/))
    call precicef_set_mesh_access_region('A-Mesh', box)
    call precicef_initialize()
    call precicef_is_coupling_ongoing(ongoing)
    do while (ongoing /= 0)
      call precicef_get_max_time_step_size(dt)
      call precicef_map_and_read_data('A-Mesh', 'V', 3, points, dt, values)
      call record(values)
      call precicef_write_and_map_data('A-Mesh', 'F', 3, points, forces)
      call precicef_write_and_map_data('A-Mesh', 'F', 1, points, single)
      call precicef_advance(dt)
      call precicef_is_coupling_ongoing(ongoing)
    end do
  end subroutine jit

  subroutine gradient()
    double precision :: grid(2, 12), s(12), v(2, 12), ds(2, 12), dv(4, 12), t = 0.0d0, dt
    integer :: ids(12), asked(2), i, j, k, ongoing
    do i = 0, 3
      do j = 0, 2
        grid(:, 3 * i + j + 1) = (/i * (1.0d0 / 3.0d0), j * 0.5d0/)      ! NumPy's linspace
      end do
    end do
    call precicef_set_vertices('A-Mesh', 12, grid, ids)
    call precicef_initialize()
    call precicef_requires_gradient_data_for('A-Mesh', 'S', asked(1))
    call precicef_requires_gradient_data_for('A-Mesh', 'V', asked(2))
    call record(dble(abs(asked)))
    call precicef_is_coupling_ongoing(ongoing)
    do while (ongoing /= 0)
      call precicef_get_max_time_step_size(dt)
      t = t + dt
      do k = 1, 12
        s(k) = t + 2 * grid(1, k) - grid(2, k)
        v(:, k) = (/grid(1, k) + 2 * grid(2, k), t * (3 * grid(1, k) - grid(2, k))/)
        ds(:, k) = (/2.0d0, -1.0d0/)
        dv(:, k) = (/1.0d0, 3.0d0 * t, 2.0d0, -t/)
      end do
      call precicef_write_data('A-Mesh', 'S', 12, ids, s)
      call precicef_write_data('A-Mesh', 'V', 12, ids, v)
      if (asked(1) /= 0) call precicef_write_gradient_data('A-Mesh', 'S', 12, ids, ds)
      if (asked(2) /= 0) call precicef_write_gradient_data('A-Mesh', 'V', 12, ids, dv)
      call precicef_advance(dt)
      call precicef_is_coupling_ongoing(ongoing)
    end do
  end subroutine gradient

  subroutine field(kind)
    character(len=*), intent(in) :: kind
    double precision :: grid(3, 20), values(20), t = 0.0d0, dt
    double precision, allocatable :: flat(:, :)
    integer :: ids(20), cells(72), axes(2, 6), n, c, i, j, k, dimensions, connectivity, ongoing
    call precicef_get_mesh_dimensions('Source-Mesh', dimensions)
    n = 0
    c = 0
    if (kind == 'tetrahedra') then               ! the unit cube's corners, vertex x + 2y + 4z
      do k = 0, 7
        grid(:, k + 1) = (/dble(iand(k, 1)), dble(iand(ishft(k, -1), 1)), dble(iand(ishft(k, -2), 1))/)
      end do
      n = 8
    else                                          ! a 5 x 4 grid on the unit square, row by row
      do j = 0, 3
        do i = 0, 4
          n = n + 1
          grid(1:2, n) = (/i * 0.25d0, j * (1.0d0 / 3.0d0)/)
        end do
      end do
    end if
    allocate(flat(dimensions, n))
    flat = grid(1:dimensions, 1:n)
    call precicef_set_mesh_vertices('Source-Mesh', n, flat, ids)
    call precicef_requires_mesh_connectivity_for('Source-Mesh', connectivity)
    call check(connectivity /= 0, 'the mapping asks for connectivity')
    select case (kind)
    case ('quads')
      do j = 0, 2
        do i = 0, 3
          cells(c + 1:c + 4) = (/5 * j + i, 5 * j + i + 1, 5 * j + i + 6, 5 * j + i + 5/)
          c = c + 4
        end do
      end do
      call precicef_set_mesh_quads('Source-Mesh', 10, cells)
      call precicef_set_mesh_quad('Source-Mesh', cells(41), cells(42), cells(43), cells(44))
      call precicef_set_quad('Source-Mesh', cells(45), cells(46), cells(47), cells(48))
    case ('triangles')
      do j = 0, 2
        do i = 0, 3
          cells(c + 1:c + 6) = (/5 * j + i, 5 * j + i + 1, 5 * j + i + 6, 5 * j + i, 5 * j + i + 6, 5 * j + i + 5/)
          c = c + 6
        end do
      end do
      call precicef_set_mesh_triangles('Source-Mesh', 22, cells)
      call precicef_set_mesh_triangle('Source-Mesh', cells(67), cells(68), cells(69))
      call precicef_set_triangle('Source-Mesh', cells(70), cells(71), cells(72))
    case ('edges')                                ! along the top row
      cells(1:4) = (/15, 16, 16, 17/)
      call precicef_set_mesh_edges('Source-Mesh', 2, cells)
      call precicef_set_mesh_edge('Source-Mesh', 17, 18)
      call precicef_set_edge('Source-Mesh', 18, 19)
    case default                                  ! Kuhn's six tetrahedra around the diagonal 0-7
      axes = reshape((/1, 2, 1, 4, 2, 1, 2, 4, 4, 1, 4, 2/), (/2, 6/))
      do k = 1, 6
        cells(c + 1:c + 4) = (/0, axes(1, k), axes(1, k) + axes(2, k), 7/)
        c = c + 4
      end do
      call precicef_set_mesh_tetrahedra('Source-Mesh', 4, cells)
      call precicef_set_mesh_tetrahedron('Source-Mesh', cells(17), cells(18), cells(19), cells(20))
      call precicef_set_tetrahedron('Source-Mesh', cells(21), cells(22), cells(23), cells(24))
    end select
    call precicef_initialize()
    call precicef_is_coupling_ongoing(ongoing)
    do while (ongoing /= 0)
      call precicef_get_max_time_step_size(dt)
      t = t + dt
      do k = 1, n
        if (dimensions == 3) then
          values(k) = t + 2.0d0 * grid(1, k) + 3.0d0 * grid(2, k) - grid(3, k)
        else
          values(k) = t + 2.0d0 * grid(1, k) + 3.0d0 * grid(2, k) * grid(2, k)
        end if
      end do
      call precicef_write_data('Source-Mesh', 'T', n, ids, values)
      call precicef_advance(dt)
      call precicef_is_coupling_ongoing(ongoing)
    end do
  end subroutine field

  subroutine reset()
    double precision :: origin(2) = (/0.0d0, 0.0d0/)
    integer :: id
    call precicef_set_mesh_vertex('A-Mesh', origin, id)
    call precicef_initialize()
    call precicef_reset_mesh('A-Mesh')
  end subroutine reset

end program tour
