"""The quick subset: the tests marked ``quick`` here (``python3 -m pytest -q -m quick``).

A few cheap tests of most test modules, chosen so that a function of nearly every module of
``fem``, ``geometry``, ``peers`` and ``whisker_opt`` runs, in under 90 s on 2 cores. Left out, as
only slow tests reach them: the fTetWild call (``geometry.tetrahedralize``), the calibration
report, the robustness command's run and report, and the CalculiX deck export. The list is kept in
one place; ``tests/test_quick_subset.py`` checks that every name in it is a test that exists.
The full suite stays the CI command.
"""

from __future__ import annotations

import signal

import pytest

# A suite started in the background of a non-interactive shell inherits SIGINT ignored, and Python then raises
# no KeyboardInterrupt, in this process or in the children it starts: the tests that interrupt a study or a
# worker's start need Ctrl-C to mean what it means at a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

#: test module -> names of its quick tests (every parametrisation of a name is included).
QUICK: dict[str, tuple[str, ...]] = {
    "test_api.py": ("test_load_config_from_a_mapping_equals_the_yaml_file", "test_load_config_refuses_other_types",
                    "test_cells_are_converted"),
    "test_aggregate.py": ("*",),
    "test_architecture.py": ("*",),
    "test_bad_inputs_more.py": ("test_a_key_given_twice_is_refused", "test_output_name_must_be_a_plain_name"),
    "test_bad_inputs_faults.py": ("test_calibrate_refuses_bounds_over_six_decades",
                                  "test_the_api_refuses_a_run_directory_of_no_path_type",
                                  "test_an_atomic_write_that_fails_names_its_file_and_leaves_nothing"),
    "test_gauge_readings.py": ("*",),
    "test_geometry_errors.py": ("*",),
    "test_beam.py": ("test_integrator_uniform_cantilever_is_euler_bernoulli", "test_uniform_tube_piecewise_closed_form",
                     "test_extension_matches_closed_form", "test_pressurised_uniform_tube_closed_form",
                     "test_bad_input_names_field_value_range"),
    "test_benchmarks_quick.py": ("test_case_list_covers_box_corners_and_edge_midpoints",
                                 "test_richardson_and_pareto_on_known_data",
                                 "test_observed_order_and_richardson_value_on_known_data"),
    "test_benchmarks_index.py": ("test_every_script_is_in_the_index_with_its_command_and_results_file",
                                 "test_every_results_file_is_reached_from_the_index",
                                 "test_no_script_imports_a_script_or_patches_sys_path",
                                 "test_no_doc_holds_a_control_character"),
    "test_best_designs.py": ("test_near_copies_of_the_best_are_not_listed_twice",
                             "test_greedy_each_design_is_the_best_one_far_enough_from_the_better_ones"),
    "test_calculix.py": ("test_write_deck_keywords_and_line_length", "test_parse_dat_handles_fortran_exponents",
                         "test_element_faces_inverts_boundary_faces", "test_deck_numbers_fit_calculix_fields",
                         "test_case_validation_names_field_and_value",
                         "test_parse_dat_totals_and_frd_displacements_read_every_phase"),
    "test_calibration.py": ("test_covariance_is_the_inverse_normal_matrix_and_flags_undetermined_parameters",
                            "test_a_malformed_file_is_one_line_naming_file_row_and_column",
                            "test_lengths_and_trims_of_a_row",
                            "test_parameters_name_real_valued_keys_within_their_range",
                            "test_the_bound_and_chi2_limits"),
    "test_calibration_starts.py": (
        "test_a_parameter_is_determined_when_its_uncertainty_is_a_quarter_of_its_range_at_most",
        "test_the_scan_is_a_centred_latin_hypercube_the_same_on_every_call"),
    "test_cli_conveniences.py": ("test_version", "test_init_writes_a_template_that_validates",
                                 "test_bad_settings_are_one_line"),
    "test_cli_errors.py": ("test_bad_option_is_one_line_before_anything_is_done",),
    "test_compensation.py": ("test_recovery_rate_and_error_hand_numbers", "test_curve_measures_scalars",
                             "test_analytic_compensation_default_design", "test_analytic_compensation_bad_input"),
    "test_compensation_map.py": ("test_lookup_is_exact_at_nodes_and_bilinear_between",
                                 "test_lookup_refuses_out_of_range_in_one_line", "test_map_arguments_are_checked"),
    "test_config_fuzz.py": ("test_fuzz_generator_is_seeded", "test_out_of_range_states_value_range_and_unit",
                            "test_unknown_keys_suggest_the_closest_key", "test_words_of_a_choice_are_listed"),
    "test_config_reference.py": ("*",),
    "test_examples.py": ("test_every_example_is_listed_and_short",),
    "test_export.py": ("test_export_refuses_a_rubber_the_deck_cannot_write",
                       "test_the_flavours_write_their_element_and_rubber"),
    "test_fem_cantilever.py": ("test_large_load_elastica",),
    "test_fem_cook.py": ("test_cook_fully_incompressible",),
    "test_fem_element.py": ("*",),
    "test_fem_fibre_field.py": ("test_reinforced_block_uniaxial_stretch_exact",
                                "test_fibre_field_residual_is_energy_gradient"),
    "test_fem_fibres.py": ("test_axial_fibre_force_in_uniaxial_stretch",),
    "test_fem_harmonic.py": ("test_plane_strain_tube_inflates_as_rivlin",
                             "test_axisymmetric_tangent_matches_finite_differences",
                             "test_axisymmetric_system_tangent_is_the_derivative_of_its_residual"),
    "test_fem_jit.py": ("*",),
    "test_fem_linsolve.py": ("*",),
    "test_fem_material_stress.py": ("*",),
    "test_fem_newton.py": ("*",),
    "test_fem_patch.py": ("test_uniaxial_incompressible", "test_simple_shear_compressible"),
    "test_fem_peer_ccx.py": ("test_displacement_formulation_tangent_matches_finite_differences",),
    "test_fem_post.py": ("*",),
    "test_fem_tangent.py": ("*",),
    "test_fem_support.py": ("*",),
    "test_fem_membrane.py": ("*",),
    "test_gauge_patches.py": ("test_registry_is_the_list_of_names", "test_vanishing_sheet_reads_as_the_bare_surface"),
    "test_base_supports.py": ("test_registry_is_the_list_of_names", "test_compliant_base_adds_the_winkler_rotation",
                              "test_grip_is_a_clamp_at_its_depth"),
    "test_fem_tensor3.py": ("*",),
    "test_fem_tube.py": ("test_tube_inflation_matches_exact_solution",),
    "test_fibre_cell.py": ("test_tiny_prescribed_increment_converges",
                           "test_2d_cell_matches_the_3d_cell_on_the_pressurised_bare_tube"),
    "test_ga_config.py": ("*",),
    "test_ga_executors.py": ("test_unpicklable_evaluator_is_refused_up_front", "test_test_fitness_is_picklable"),
    "test_ga_initial_population.py": ("*",),
    "test_ga_loop.py": ("test_max_generations_rule", "test_genes_never_leave_their_bounds",
                        "test_evaluator_outcome_types_are_checked",
                        "test_resolution_rule_ends_the_run_after_n_generations_of_best_f1_below_the_resolution",
                        "test_a_recorder_sees_each_generation_once_in_order"),
    "test_ga_penalty.py": ("*",),
    "test_ga_storage.py": ("test_plot_helpers_and_atomic_writers",),
    "test_geometry_cad.py": ("test_frustum_closed_forms_against_quadrature", "test_cad_refuses_invalid_design"),
    "test_geometry_design.py": ("*",),
    "test_geometry_fibre_field.py": ("*",),
    "test_geometry_mesh.py": ("test_templates_are_shipped_and_small", "test_radius_ratio_of_regular_tet_is_one",
                              "test_template_path_is_deterministic", "test_invalid_design_refused_before_meshing",
                              "test_fresh_path_keeps_three_wall_layers"),
    "test_geometry_surface.py": ("*",),
    "test_geometry_swept.py": ("test_cross_section_tiles_the_unit_disc",
                               "test_prism_split_is_conforming_for_any_numbering"),
    "test_kill_resume.py": ("test_temporaries_are_recognised",),
    "test_linear_solver_key.py": ("*",),
    "test_model_form.py": ("test_shipped_yeoh_constants_pass_through_the_published_points",
                           "test_elementwise_tangent_matches_fd", "test_elementwise_material_refuses_bad_input",
                           "test_scene_spec_refuses_unknown_options", "test_default_options_are_todays_model"),
    "test_nsga2.py": ("test_spread_keeps_both_ends_and_the_count", "test_stall_rule_on_the_hypervolume",
                      "test_finer_preset", "test_pareto_outputs_verification_and_report"),
    "test_pareto.py": ("*",),
    "test_plots.py": ("test_presets_carry_a_measured_f1_resolution", "test_convergence_ticks_are_whole_generations",
                      "test_curves_figure_has_a_residual_panel_whose_mean_is_f1",
                      "test_compensation_figure_labels_bounds_target_and_preset"),
    "test_progress.py": ("test_a_progress_line_states_the_count_the_elapsed_time_and_the_eta",
                         "test_executor_callback_sees_each_design_once_and_changes_nothing"),
    "test_quick_subset.py": ("*",),
    "test_robustness.py": ("test_sample_of_a_linear_function_has_the_closed_form_std",
                           "test_latin_hypercube_hits_every_stratum_once_and_uniform_stays_in_the_band",
                           "test_the_same_seed_gives_the_same_sample", "test_bad_half_widths_are_refused",
                           "test_robust_objective_is_mean_plus_k_std", "test_default_tolerances_are_those_stated",
                           "test_a_sample_too_small_for_the_sensitivities_is_refused_in_one_line"),
    "test_rubber_laws.py": ("*",),
    "test_rundir_safety.py": ("test_the_lock_names_its_holder_and_is_gone_after_it",),
    "test_scene.py": ("test_contact_band_refuses_an_empty_band",),
    "test_unread_keys.py": ("test_each_command_names_every_set_key_it_does_not_read",
                            "test_every_job_warns_with_its_own_command"),
    "test_viewer.py": ("test_axial_log_strain_closed_forms", "test_split_stem_and_state_order",
                       "test_von_mises_uniaxial_closed_form", "test_rank_and_eval_selection",
                       "test_discover_run_directory", "test_fields_and_errors",
                       "test_side_by_side_compare_with_markers", "test_cli_screenshot_list_plots_and_errors"),
    "test_state_validation.py": ("test_individuals_off_the_genome_are_refused",),
    "test_study_resume.py": ("test_a_study_into_a_locked_folder_is_refused_in_one_line",),
    "test_viewer_stored_fields.py": ("test_computed_von_mises_closed_form",),
    "test_wall_cell.py": ("test_a_bad_mechanism_names_its_field", "test_a_fibre_outside_the_wall_is_refused"),
    "test_wall_table.py": ("test_the_table_round_trips_and_interpolates_linearly",
                           "test_the_table_refuses_what_it_does_not_hold", "test_inferred_k_inverts_the_thesis_model"),
}


def pytest_collection_modifyitems(config, items) -> None:
    """Mark the tests of :data:`QUICK` with ``quick``."""
    for item in items:
        names = QUICK.get(item.path.name, ())
        if "*" in names or getattr(item, "originalname", item.name) in names:
            item.add_marker(pytest.mark.quick)
